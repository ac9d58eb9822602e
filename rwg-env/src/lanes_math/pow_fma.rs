//! Derived from Arm's optimized-routines `math/pow.c` (Copyright (c)
//! 2018-2020, Arm Limited; MIT OR Apache-2.0 WITH LLVM-exception), the code
//! glibc's `pow` has used since 2.28; credited in THIRD-PARTY-NOTICES at the
//! repository's root.
//!
//! `pow(x, 2.0)` four lanes at a time: the operations of glibc 2.36's x86-64
//! `__pow_fma` (the variant its `pow` ifunc picks on CPUs with AVX2 and FMA)
//! for `y = 2` and 2^-60 <= |x| <= 2^32, |x| != 1, with AVX2+FMA intrinsics.
//!
//! glibc compiles `sysdeps/ieee754/dbl-64/e_pow.c` for that variant with
//! `-mfma -mavx2`: its explicit `fma` calls are fused, and GCC fused some
//! products into the following additions as well. Which ones was read off the
//! machine code of `__pow_fma` in Debian 12's libm (2.36-9): every `fmadd` /
//! `fmsub` below stands where that code has a fused instruction, every
//! `mul` followed by an `add` where it has two, with the same operands
//! (products and sums are commutative bit for bit, so only the grouping
//! matters). The constants are the bits that code loads. Rust never fuses by
//! itself, so these are exactly glibc's roundings.
//!
//! The algorithm (ARM's optimized-routines pow, glibc's since 2.28):
//! `log|x|` as `hi + lo` from a 128-entry table and a degree-8 polynomial,
//! `2·log|x|` (exact: `y = 2`), then `exp` of that from a 128-entry table of
//! 2^(k/128) and a degree-5 polynomial, with one final rounding in
//! `scale + scale·tmp`. In the range above none of glibc's special cases
//! apply: `x` is finite, normal and non-zero; a negative `x` takes glibc's
//! branch that clears the sign (2 is an even integer) and continues with
//! `|x|`; `2·log|x|` lies within [-84, 45] and, for |x| != 1, beyond 2^-54
//! in magnitude, so `exp`'s special-case test never fires. |x| = 1 is left
//! out because glibc's `exp` returns `1 + x` for that tiny-argument case;
//! `pow2_lanes` never sends it here (1 is an exact square).
//!
//! The computation is written once, over the vector operations of the
//! trait [`Lanes`]: implemented here for four AVX2+FMA lanes (`__m256d`)
//! and in `pow_avx512` for eight AVX-512 lanes (`__m512d`). Both run the same
//! floating-point operations in the same order, fused at the same places, so
//! they give the same bits; they differ only in exact integer steps and in
//! how they read the tables.
//!
//! Every function is `unsafe` only because it is compiled for its
//! instruction set (`#[target_feature]`, which trait methods cannot carry
//! on safe functions): calling it is sound on a CPU with that set, which
//! [`super::Vector::detect`] (or the AVX-512 level's detection) checks
//! before the entry points are reachable. Here table reads are row loads
//! (cheaper than gathers on four lanes) at indices masked into the tables,
//! whatever a lane holds.

use super::pow_table::{EXP_TAB, LOG_TAB};
use std::arch::x86_64::*;

/// Smallest |x| of the port: 2^-60, the bound of `pow2`'s 0.48-ulp fast path.
const MIN: f64 = crate::float::TIGHT_MIN;
/// Largest |x| of the port: 2^32.
const MAX: f64 = crate::float::TIGHT_MAX;

// log: x = 2^k z, z in [OFF, 2 OFF).
const OFF: i64 = 0x3fe6_9555_0000_0000;
const LN2HI: f64 = f64::from_bits(0x3fe6_2e42_fefa_3800);
const LN2LO: f64 = f64::from_bits(0x3d2e_f357_93c7_6730);
const A0: f64 = f64::from_bits(0xbfe0_0000_0000_0000); // -0.5
const A1: f64 = f64::from_bits(0xbfe5_5555_5555_5560);
const A2: f64 = f64::from_bits(0x3fe0_0000_0000_0006);
const A3: f64 = f64::from_bits(0x3fe9_9999_9959_554e);
const A4: f64 = f64::from_bits(0xbfe5_5555_5529_a47a);
const A5: f64 = f64::from_bits(0xbff2_495b_9b48_45e9);
const A6: f64 = f64::from_bits(0x3ff0_002b_8b26_3fc3);
// exp: x = k ln2/128 + r.
const INVLN2N: f64 = f64::from_bits(0x4067_1547_652b_82fe);
const NEGLN2HIN: f64 = f64::from_bits(0xbf76_2e42_fefa_0000);
const NEGLN2LON: f64 = f64::from_bits(0xbd0c_f79a_bc9e_3b3a);
const SHIFT: f64 = f64::from_bits(0x4338_0000_0000_0000); // 1.5 * 2^52
const C2: f64 = f64::from_bits(0x3fdf_ffff_ffff_fdbd);
const C3: f64 = f64::from_bits(0x3fc5_5555_5555_543c);
const C4: f64 = f64::from_bits(0x3fa5_5555_cf17_2b91);
const C5: f64 = f64::from_bits(0x3f81_1111_67a4_d017);
/// The exponent `y`.
const Y: f64 = 2.0;

/// The vector operations the port is written in: `Self` holds one `f64`
/// per lane, [`Lanes::I`] one 64-bit integer per lane, [`Lanes::M`] one
/// truth value per lane. Every floating-point method is one IEEE operation
/// (rounded to nearest) per lane, so an implementation changes no bits.
pub(super) trait Lanes: Copy {
    /// 64-bit integers, one per lane.
    type I: Copy;
    /// Per-lane truth values (a comparison's result).
    type M: Copy;

    /// `v` in every lane.
    unsafe fn splat(v: f64) -> Self;
    /// `v` in every lane.
    unsafe fn splat_i(v: i64) -> Self::I;
    /// `self + b`.
    unsafe fn add(self, b: Self) -> Self;
    /// `self - b`.
    unsafe fn sub(self, b: Self) -> Self;
    /// `self * b`.
    unsafe fn mul(self, b: Self) -> Self;
    /// `self * b + c`, rounded once.
    unsafe fn fmadd(self, b: Self, c: Self) -> Self;
    /// `self * b - c`, rounded once.
    unsafe fn fmsub(self, b: Self, c: Self) -> Self;
    /// `|self|` (the sign bit cleared).
    unsafe fn abs(self) -> Self;
    /// The bits of each lane.
    unsafe fn to_bits(self) -> Self::I;
    /// The lanes with bits `i`.
    unsafe fn from_bits(i: Self::I) -> Self;
    /// `a + b`, wrapping.
    unsafe fn add_i(a: Self::I, b: Self::I) -> Self::I;
    /// `a - b`, wrapping.
    unsafe fn sub_i(a: Self::I, b: Self::I) -> Self::I;
    /// `a & b`.
    unsafe fn and_i(a: Self::I, b: Self::I) -> Self::I;
    /// `a >> 45`, shifting in zeros.
    unsafe fn shr45(a: Self::I) -> Self::I;
    /// `a << 45`.
    unsafe fn shl45(a: Self::I) -> Self::I;
    /// `(double) (a >> 52)` with an arithmetic shift (exact).
    unsafe fn top12(a: Self::I) -> Self;
    /// `[invc, logc, logctail]` of the log table's rows `i` (each taken mod
    /// 128).
    unsafe fn log_rows(i: Self::I) -> [Self; 3];
    /// `(tail, sbits)` of the exp table's pairs `k` (each taken mod 128).
    unsafe fn exp_pairs(k: Self::I) -> (Self, Self);
    /// `a >= b` (false for NaN).
    unsafe fn ge(a: Self, b: Self) -> Self::M;
    /// `a <= b` (false for NaN).
    unsafe fn le(a: Self, b: Self) -> Self::M;
    /// `a == b` (false for NaN).
    unsafe fn eq(a: Self, b: Self) -> Self::M;
    /// `a && b`.
    unsafe fn and_m(a: Self::M, b: Self::M) -> Self::M;
    /// `!a && b`.
    unsafe fn andnot_m(a: Self::M, b: Self::M) -> Self::M;
}

/// `log_inline(|x|)`: `(hi, lo)` with `hi + lo` = log|x| to ~2^-68.
#[inline(always)]
unsafe fn log_hi_lo<V: Lanes>(x: V) -> (V, V) {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point) guarantees.
    unsafe {
        let ix = x.abs().to_bits();
        let tmp = V::sub_i(ix, V::splat_i(OFF));
        // i = (tmp >> 45) % 128; k = (int64) tmp >> 52.
        let i = V::and_i(V::shr45(tmp), V::splat_i(127));
        let kd = V::top12(tmp);
        let iz = V::sub_i(ix, V::and_i(tmp, V::splat_i(0xfff << 52)));
        let z = V::from_bits(iz);
        let [invc, logc, logctail] = V::log_rows(i);

        let r = z.fmadd(invc, V::splat(-1.0));
        let t1 = kd.fmadd(V::splat(LN2HI), logc);
        let lo1 = kd.fmadd(V::splat(LN2LO), logctail);
        let t2 = t1.add(r);
        let lo2 = t1.sub(t2).add(r);
        let ar = V::splat(A0).mul(r);
        let ar2 = r.mul(ar);
        let ar3 = r.mul(ar2);
        let hi = t2.add(ar2);
        let lo3 = ar.fmsub(r, ar2);
        let lo4 = t2.sub(hi).add(ar2);
        // p = ar3 * (A1 + r A2 + ar2 (A3 + r A4 + ar2 (A5 + r A6))), the last
        // product fused into the sum of the lo terms.
        let q5 = r.fmadd(V::splat(A6), V::splat(A5));
        let q3 = ar2.fmadd(q5, r.fmadd(V::splat(A4), V::splat(A3)));
        let q1 = ar2.fmadd(q3, r.fmadd(V::splat(A2), V::splat(A1)));
        let lo = lo1.add(lo2).add(lo3).add(lo4);
        let lo = ar3.fmadd(q1, lo);
        let y = hi.add(lo);
        let tail = hi.sub(y).add(lo);
        (y, tail)
    }
}

/// `exp_inline(x, xtail, 0)` for 2^-54 <= |x| < 512.
#[inline(always)]
unsafe fn exp_hi_lo<V: Lanes>(x: V, xtail: V) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point) guarantees.
    unsafe {
        let kd = x.fmadd(V::splat(INVLN2N), V::splat(SHIFT));
        let ki = kd.to_bits();
        let kd = kd.sub(V::splat(SHIFT));
        let r = kd.fmadd(V::splat(NEGLN2HIN), x);
        let r = kd.fmadd(V::splat(NEGLN2LON), r);
        let r = r.add(xtail);
        let top = V::shl45(ki);
        let (tail, sbits) = V::exp_pairs(V::and_i(ki, V::splat_i(127)));
        let sbits = V::add_i(sbits.to_bits(), top);
        let r2 = r.mul(r);
        let tmp = r.fmadd(V::splat(C3), V::splat(C2)).fmadd(r2, r.add(tail));
        let tmp = r.fmadd(V::splat(C5), V::splat(C4)).fmadd(r2.mul(r2), tmp);
        let scale = V::from_bits(sbits);
        tmp.fmadd(scale, scale)
    }
}

/// glibc's `pow(x, 2.0)` for 2^-60 <= |x| <= 2^32, |x| != 1 (other lanes
/// get meaningless values).
#[inline(always)]
pub(super) unsafe fn pow2<V: Lanes>(x: V) -> V {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point) guarantees.
    unsafe {
        let (hi, lo) = log_hi_lo(x);
        let ehi = V::splat(Y).mul(hi);
        let elo = V::splat(Y).fmadd(lo, hi.fmsub(V::splat(Y), ehi));
        exp_hi_lo(ehi, elo)
    }
}

/// Lanes where the port applies: 2^-60 <= |x| <= 2^32 and |x| != 1 (false
/// for NaN).
#[inline(always)]
pub(super) unsafe fn in_range<V: Lanes>(x: V) -> V::M {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point) guarantees.
    unsafe {
        let ax = x.abs();
        let inside = V::and_m(V::ge(ax, V::splat(MIN)), V::le(ax, V::splat(MAX)));
        V::andnot_m(V::eq(ax, V::splat(1.0)), inside)
    }
}

/// `p = x*x` and the lanes where `p` is `pow(x, 2)` for certain
/// ([`crate::float::pow2`]'s 0.48-ulp fast path: in the port's range and
/// the exact square within 0.48 ulp of `p`).
#[inline(always)]
pub(super) unsafe fn square_fast<V: Lanes>(x: V) -> (V, V::M) {
    // SAFETY: `Lanes` methods only: sound on a CPU with `V`'s instruction
    // set, which the caller (an entry point) guarantees.
    unsafe {
        let p = x.mul(x);
        let e = x.fmsub(x, p).abs();
        // ulp(p) = 2^(exponent - 52); p >= 2^-120 is normal here.
        let ulp = V::from_bits(V::sub_i(
            V::and_i(p.to_bits(), V::splat_i(0x7ff0_0000_0000_0000)),
            V::splat_i(52 << 52),
        ));
        let ax = x.abs();
        let tight = V::and_m(V::ge(ax, V::splat(MIN)), V::le(ax, V::splat(MAX)));
        let near = V::le(e, V::splat(0.48).mul(ulp));
        (p, V::and_m(tight, near))
    }
}

/// `out[j] = slow(x[j])` for every lane `j` whose bit is set in `lanes`.
#[inline]
pub(super) fn slow_lanes(lanes: u32, x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    if lanes != 0 {
        for (j, (o, &a)) in out.iter_mut().zip(x).enumerate() {
            if lanes >> j & 1 == 1 {
                *o = slow(a);
            }
        }
    }
}

type V4 = __m256d;
type I4 = __m256i;

/// The four 64-bit lanes of `v`, as table indices.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn lanes(v: I4) -> [usize; 4] {
    let mut k = [0u64; 4];
    // SAFETY: `k` is 32 writable bytes (an unaligned store).
    unsafe { _mm256_storeu_si256(k.as_mut_ptr().cast(), v) };
    k.map(|k| k as usize)
}

impl Lanes for V4 {
    type I = I4;
    type M = V4;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn splat(v: f64) -> V4 {
        _mm256_set1_pd(v)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn splat_i(v: i64) -> I4 {
        _mm256_set1_epi64x(v)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn add(self, b: V4) -> V4 {
        _mm256_add_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn sub(self, b: V4) -> V4 {
        _mm256_sub_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn mul(self, b: V4) -> V4 {
        _mm256_mul_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fmadd(self, b: V4, c: V4) -> V4 {
        _mm256_fmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fmsub(self, b: V4, c: V4) -> V4 {
        _mm256_fmsub_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn abs(self) -> V4 {
        _mm256_andnot_pd(_mm256_set1_pd(-0.0), self)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn to_bits(self) -> I4 {
        _mm256_castpd_si256(self)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn from_bits(i: I4) -> V4 {
        _mm256_castsi256_pd(i)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn add_i(a: I4, b: I4) -> I4 {
        _mm256_add_epi64(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn sub_i(a: I4, b: I4) -> I4 {
        _mm256_sub_epi64(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn and_i(a: I4, b: I4) -> I4 {
        _mm256_and_si256(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn shr45(a: I4) -> I4 {
        _mm256_srli_epi64::<45>(a)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn shl45(a: I4) -> I4 {
        _mm256_slli_epi64::<45>(a)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn top12(a: I4) -> V4 {
        // AVX2 has no 64-bit arithmetic shift: sign-extend the top 12 bits
        // by hand; then 1.5 * 2^52 + k - 1.5 * 2^52 = k exactly for
        // |k| < 2^51.
        let top = _mm256_srli_epi64::<52>(a);
        let k = _mm256_sub_epi64(
            _mm256_xor_si256(top, _mm256_set1_epi64x(0x800)),
            _mm256_set1_epi64x(0x800),
        );
        _mm256_sub_pd(
            _mm256_castsi256_pd(_mm256_add_epi64(
                k,
                _mm256_set1_epi64x(SHIFT.to_bits() as i64),
            )),
            _mm256_set1_pd(SHIFT),
        )
    }
    /// Four aligned row loads and a transpose.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn log_rows(i: I4) -> [V4; 3] {
        let t = LOG_TAB.0.as_ptr();
        // SAFETY: `k & 127` is a row of the table, 32-byte aligned (the
        // caller's indices are in 0..128 already; the mask makes the reads
        // safe whatever they are).
        let row = |k: usize| unsafe { _mm256_load_pd(t.add(k & 127).cast()) };
        // SAFETY: the CPU has AVX2 (this function's own precondition).
        let [a, b, c, d] = unsafe { lanes(i) };
        let (r0, r1, r2, r3) = (row(a), row(b), row(c), row(d));
        let t0 = _mm256_unpacklo_pd(r0, r1); // invc0 invc1 logctail0 logctail1
        let t1 = _mm256_unpackhi_pd(r0, r1); // logc0 logc1 0 0
        let t2 = _mm256_unpacklo_pd(r2, r3);
        let t3 = _mm256_unpackhi_pd(r2, r3);
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
        ]
    }
    /// Four pair loads and an unpack.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn exp_pairs(k: I4) -> (V4, V4) {
        let t = EXP_TAB.as_ptr();
        // SAFETY: with `k & 127`, 2k + 1 < 256 (as for `log_rows`, the mask
        // only guards the reads; an unaligned load).
        let pair = |k: usize| unsafe { _mm_loadu_pd(t.add(2 * (k & 127)).cast()) };
        // SAFETY: the CPU has AVX2 (this function's own precondition).
        let [a, b, c, d] = unsafe { lanes(k) };
        let lo = _mm256_set_m128d(pair(c), pair(a)); // tail_a sbits_a tail_c sbits_c
        let hi = _mm256_set_m128d(pair(d), pair(b));
        (_mm256_unpacklo_pd(lo, hi), _mm256_unpackhi_pd(lo, hi))
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn ge(a: V4, b: V4) -> V4 {
        _mm256_cmp_pd::<_CMP_GE_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn le(a: V4, b: V4) -> V4 {
        _mm256_cmp_pd::<_CMP_LE_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn eq(a: V4, b: V4) -> V4 {
        _mm256_cmp_pd::<_CMP_EQ_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn and_m(a: V4, b: V4) -> V4 {
        _mm256_and_pd(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn andnot_m(a: V4, b: V4) -> V4 {
        _mm256_andnot_pd(a, b)
    }
}

/// `out[i] = pow(x[i], 2)` with libm's bits: the fast path where it settles
/// the result, the port for the other lanes in its range (a group of four
/// with no such lane skips it), `slow` (`pow2`) for the rest.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn pow2_lanes(x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    let mut xs = x.chunks_exact(4);
    let mut os = out.chunks_exact_mut(4);
    for (xc, oc) in (&mut xs).zip(&mut os) {
        // SAFETY: `xc` and `oc` are four `f64` each (unaligned loads and
        // stores); the CPU has AVX2 and FMA (this function's precondition),
        // what the kernels need.
        let v = unsafe { _mm256_loadu_pd(xc.as_ptr()) };
        // SAFETY: as above.
        let (p, fast) = unsafe { square_fast(v) };
        if _mm256_movemask_pd(fast) == 0b1111 {
            // SAFETY: as above.
            unsafe { _mm256_storeu_pd(oc.as_mut_ptr(), p) };
            continue;
        }
        // SAFETY: as above.
        let (port, q) = unsafe { (in_range(v), pow2(v)) };
        // SAFETY: as above.
        unsafe { _mm256_storeu_pd(oc.as_mut_ptr(), _mm256_blendv_pd(q, p, fast)) };
        let libm = !_mm256_movemask_pd(_mm256_or_pd(fast, port)) & 0b1111;
        slow_lanes(libm as u32, xc, oc, slow);
    }
    for (o, &a) in os.into_remainder().iter_mut().zip(xs.remainder()) {
        *o = slow(a);
    }
}

/// The port alone for every lane in its range (libm `slow` for the rest),
/// without the fast path: what `rwg bench libm --check` compares with libm.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn pow2_port_lanes(x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    let mut xs = x.chunks_exact(4);
    let mut os = out.chunks_exact_mut(4);
    for (xc, oc) in (&mut xs).zip(&mut os) {
        // SAFETY: as in `pow2_lanes`.
        let v = unsafe { _mm256_loadu_pd(xc.as_ptr()) };
        // SAFETY: as in `pow2_lanes`.
        let (q, inside) = unsafe { (pow2(v), in_range(v)) };
        // SAFETY: as in `pow2_lanes`.
        unsafe { _mm256_storeu_pd(oc.as_mut_ptr(), q) };
        let outside = !_mm256_movemask_pd(inside) & 0b1111;
        slow_lanes(outside as u32, xc, oc, slow);
    }
    for (o, &a) in os.into_remainder().iter_mut().zip(xs.remainder()) {
        *o = slow(a);
    }
}
