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
//! Every function is `unsafe` only because it is compiled for AVX2+FMA
//! (`#[target_feature]`; safe target-feature functions need Rust 1.86, the
//! workspace supports 1.85): calling it is sound on a CPU with both, which
//! [`super::Vector::detect`] checks before the entry points are reachable.
//! Table reads are row loads (cheaper than gathers) at indices masked into
//! the tables, whatever a lane holds.

use super::pow_table::{EXP_TAB, LOG_TAB};
use std::arch::x86_64::*;

type V = __m256d;
type I = __m256i;

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

/// `v` in all four lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn splat(v: f64) -> V {
    _mm256_set1_pd(v)
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn splat_i(v: i64) -> I {
    _mm256_set1_epi64x(v)
}

/// The four 64-bit lanes of `v`, as table indices.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn lanes(v: I) -> [usize; 4] {
    let mut k = [0u64; 4];
    _mm256_storeu_si256(k.as_mut_ptr().cast(), v);
    k.map(|k| k as usize)
}

/// `[invc, logc, logctail]` of the log table's rows `i` (each taken mod
/// 128): four aligned row loads and a transpose.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn log_rows(i: I) -> [V; 3] {
    let t = LOG_TAB.0.as_ptr();
    // SAFETY (for the caller's unsafe block): `k & 127` is a row of the
    // table (the caller's indices are in 0..128 already; the mask makes the
    // reads safe whatever they are).
    let row = |k: usize| _mm256_load_pd(t.add(k & 127).cast());
    let [a, b, c, d] = lanes(i);
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

/// `(tail, sbits)` of the exp table's pairs `k` (each taken mod 128): four
/// pair loads and an unpack.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn exp_pairs(k: I) -> (V, V) {
    let t = EXP_TAB.as_ptr();
    // SAFETY (for the caller's unsafe block): with `k & 127`, 2k + 1 < 256
    // (as for `log_rows`, the mask only guards the reads).
    let pair = |k: usize| _mm_loadu_pd(t.add(2 * (k & 127)).cast());
    let [a, b, c, d] = lanes(k);
    let lo = _mm256_set_m128d(pair(c), pair(a)); // tail_a sbits_a tail_c sbits_c
    let hi = _mm256_set_m128d(pair(d), pair(b));
    (_mm256_unpacklo_pd(lo, hi), _mm256_unpackhi_pd(lo, hi))
}

/// `log_inline(|x|)`: `(hi, lo)` with `hi + lo` = log|x| to ~2^-68.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn log_hi_lo(x: V) -> (V, V) {
    let ix = _mm256_castpd_si256(_mm256_andnot_pd(splat(-0.0), x));
    let tmp = _mm256_sub_epi64(ix, splat_i(OFF));
    // i = (tmp >> 45) % 128; k = (int64) tmp >> 52 (AVX2 has no 64-bit
    // arithmetic shift: sign-extend the top 12 bits by hand).
    let i = _mm256_and_si256(_mm256_srli_epi64::<45>(tmp), splat_i(127));
    let top = _mm256_srli_epi64::<52>(tmp);
    let k = _mm256_sub_epi64(_mm256_xor_si256(top, splat_i(0x800)), splat_i(0x800));
    // (double) k, exactly: 1.5 * 2^52 + k - 1.5 * 2^52 for |k| < 2^51.
    let kd = _mm256_sub_pd(
        _mm256_castsi256_pd(_mm256_add_epi64(k, splat_i(SHIFT.to_bits() as i64))),
        splat(SHIFT),
    );
    let iz = _mm256_sub_epi64(ix, _mm256_and_si256(tmp, splat_i(0xfff << 52)));
    let z = _mm256_castsi256_pd(iz);
    let [invc, logc, logctail] = log_rows(i);

    let r = _mm256_fmadd_pd(z, invc, splat(-1.0));
    let t1 = _mm256_fmadd_pd(kd, splat(LN2HI), logc);
    let lo1 = _mm256_fmadd_pd(kd, splat(LN2LO), logctail);
    let t2 = _mm256_add_pd(t1, r);
    let lo2 = _mm256_add_pd(_mm256_sub_pd(t1, t2), r);
    let ar = _mm256_mul_pd(splat(A0), r);
    let ar2 = _mm256_mul_pd(r, ar);
    let ar3 = _mm256_mul_pd(r, ar2);
    let hi = _mm256_add_pd(t2, ar2);
    let lo3 = _mm256_fmsub_pd(ar, r, ar2);
    let lo4 = _mm256_add_pd(_mm256_sub_pd(t2, hi), ar2);
    // p = ar3 * (A1 + r A2 + ar2 (A3 + r A4 + ar2 (A5 + r A6))), the last
    // product fused into the sum of the lo terms.
    let q5 = _mm256_fmadd_pd(r, splat(A6), splat(A5));
    let q3 = _mm256_fmadd_pd(ar2, q5, _mm256_fmadd_pd(r, splat(A4), splat(A3)));
    let q1 = _mm256_fmadd_pd(ar2, q3, _mm256_fmadd_pd(r, splat(A2), splat(A1)));
    let lo = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(lo1, lo2), lo3), lo4);
    let lo = _mm256_fmadd_pd(ar3, q1, lo);
    let y = _mm256_add_pd(hi, lo);
    let tail = _mm256_add_pd(_mm256_sub_pd(hi, y), lo);
    (y, tail)
}

/// `exp_inline(x, xtail, 0)` for 2^-54 <= |x| < 512.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn exp_hi_lo(x: V, xtail: V) -> V {
    let kd = _mm256_fmadd_pd(x, splat(INVLN2N), splat(SHIFT));
    let ki = _mm256_castpd_si256(kd);
    let kd = _mm256_sub_pd(kd, splat(SHIFT));
    let r = _mm256_fmadd_pd(kd, splat(NEGLN2HIN), x);
    let r = _mm256_fmadd_pd(kd, splat(NEGLN2LON), r);
    let r = _mm256_add_pd(r, xtail);
    let top = _mm256_slli_epi64::<45>(ki);
    let (tail, sbits) = exp_pairs(_mm256_and_si256(ki, splat_i(127)));
    let sbits = _mm256_add_epi64(_mm256_castpd_si256(sbits), top);
    let r2 = _mm256_mul_pd(r, r);
    let tmp = _mm256_fmadd_pd(
        _mm256_fmadd_pd(r, splat(C3), splat(C2)),
        r2,
        _mm256_add_pd(r, tail),
    );
    let tmp = _mm256_fmadd_pd(
        _mm256_fmadd_pd(r, splat(C5), splat(C4)),
        _mm256_mul_pd(r2, r2),
        tmp,
    );
    let scale = _mm256_castsi256_pd(sbits);
    _mm256_fmadd_pd(tmp, scale, scale)
}

/// glibc's `pow(x, 2.0)` for 2^-60 <= |x| <= 2^32, |x| != 1 (other lanes
/// get meaningless values).
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn pow2(x: V) -> V {
    let (hi, lo) = log_hi_lo(x);
    let ehi = _mm256_mul_pd(splat(Y), hi);
    let elo = _mm256_fmadd_pd(splat(Y), lo, _mm256_fmsub_pd(hi, splat(Y), ehi));
    exp_hi_lo(ehi, elo)
}

/// Lanes where the port applies: 2^-60 <= |x| <= 2^32 and |x| != 1 (false
/// for NaN).
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn in_range(x: V) -> V {
    let ax = _mm256_andnot_pd(splat(-0.0), x);
    let inside = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GE_OQ>(ax, splat(MIN)),
        _mm256_cmp_pd::<_CMP_LE_OQ>(ax, splat(MAX)),
    );
    _mm256_andnot_pd(_mm256_cmp_pd::<_CMP_EQ_OQ>(ax, splat(1.0)), inside)
}

/// `p = x*x` and the lanes where `p` is `pow(x, 2)` for certain
/// ([`crate::float::pow2`]'s 0.48-ulp fast path: in the port's range and
/// the exact square within 0.48 ulp of `p`).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn square_fast(x: V) -> (V, V) {
    let p = _mm256_mul_pd(x, x);
    let e = _mm256_andnot_pd(splat(-0.0), _mm256_fmsub_pd(x, x, p));
    // ulp(p) = 2^(exponent - 52); p >= 2^-120 is normal here.
    let ulp = _mm256_castsi256_pd(_mm256_sub_epi64(
        _mm256_and_si256(_mm256_castpd_si256(p), splat_i(0x7ff0_0000_0000_0000)),
        splat_i(52 << 52),
    ));
    let ax = _mm256_andnot_pd(splat(-0.0), x);
    let tight = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GE_OQ>(ax, splat(MIN)),
        _mm256_cmp_pd::<_CMP_LE_OQ>(ax, splat(MAX)),
    );
    let near = _mm256_cmp_pd::<_CMP_LE_OQ>(e, _mm256_mul_pd(splat(0.48), ulp));
    (p, _mm256_and_pd(tight, near))
}

/// `out[i] = pow(x[i], 2)` with libm's bits: the fast path where it settles
/// the result, the port for the other lanes in its range (a group of four
/// with no such lane skips it), `pow2` (libm) for the rest.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn pow2_lanes(x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    let mut xs = x.chunks_exact(4);
    let mut os = out.chunks_exact_mut(4);
    for (xc, oc) in (&mut xs).zip(&mut os) {
        let v = _mm256_loadu_pd(xc.as_ptr());
        let (p, fast) = square_fast(v);
        let all = _mm256_movemask_pd(fast);
        if all == 0b1111 {
            _mm256_storeu_pd(oc.as_mut_ptr(), p);
            continue;
        }
        let port = in_range(v);
        _mm256_storeu_pd(oc.as_mut_ptr(), _mm256_blendv_pd(pow2(v), p, fast));
        let libm = !_mm256_movemask_pd(_mm256_or_pd(fast, port)) & 0b1111;
        if libm != 0 {
            for (j, (o, &a)) in oc.iter_mut().zip(xc).enumerate() {
                if libm >> j & 1 == 1 {
                    *o = slow(a);
                }
            }
        }
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
        let v = _mm256_loadu_pd(xc.as_ptr());
        _mm256_storeu_pd(oc.as_mut_ptr(), pow2(v));
        let outside = !_mm256_movemask_pd(in_range(v)) & 0b1111;
        for (j, (o, &a)) in oc.iter_mut().zip(xc).enumerate() {
            if outside >> j & 1 == 1 {
                *o = slow(a);
            }
        }
    }
    for (o, &a) in os.into_remainder().iter_mut().zip(xs.remainder()) {
        *o = slow(a);
    }
}
