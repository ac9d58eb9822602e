//! Derived from glibc's `sysdeps/ieee754/dbl-64/s_sin.c` (IBM Accurate
//! Mathematical Library, written by International Business Machines Corp.;
//! Copyright (C) 2001-2022 Free Software Foundation, Inc.), under the GNU
//! Lesser General Public License 2.1 or (at your option) any later version:
//! see the crate's `COPYING`.
//!
//! Four lanes at a time: the operations of glibc 2.36's x86-64 `__sin_fma`
//! and `__cos_fma` (the variants its `sin`/`cos` ifuncs pick on CPUs with
//! AVX2 and FMA), for |x| < 105414350, with AVX2+FMA intrinsics.
//!
//! glibc compiles `sysdeps/ieee754/dbl-64/s_sin.c` for that variant with
//! `-mfma -mavx2`, so GCC fused some products into the following additions.
//! Which ones was read off the machine code of `__sin_fma`/`__cos_fma` in
//! Debian 12's libm (2.36-9): every `fmadd`/`fnmadd`/`fmsub` below stands
//! where that code has a fused instruction, every `mul` + `add` where it has
//! two; the constants are the bits that code loads. Rust never fuses by
//! itself, so these are exactly the roundings glibc performs.
//!
//! Paths (k = |x|, as glibc tests the high word; sin / cos):
//! - k < 2^-26 / 2^-27: `x` / `1.0`;
//! - k < 0.855469: `do_sin(x, 0)` / `do_cos(x, 0)`; `do_sin` is a Taylor
//!   polynomial when |a| < 0.126, else a table lookup at the nearest k/128;
//! - k < 2.426265: sin = `copysign(do_cos(pi/2 - |x|, hp1), x)`, cos =
//!   `do_sin(a, da)` with `a + da` = pi/2 - |x| split in two;
//! - k < 105414350: the three-constant reduction by pi/2 to `(a, da, n)`,
//!   then `do_sin` or `do_cos` by quadrant, negated in quadrants 2 and 3.
//!
//! Lanes beyond (huge, ±inf, NaN) are flagged for the caller, which computes
//! them with libm. Lanes on different paths are all computed and blended; a
//! kernel no lane needs is skipped.
//!
//! Every function here is `unsafe` only because it is compiled for AVX2+FMA
//! (`#[target_feature]`; safe target-feature functions need Rust 1.86, the
//! workspace supports 1.85): calling it is sound on a CPU with both, which
//! the caller of the three entry points checks (`rwg_env::lanes_math`'s
//! `Vector::detect`). The only memory accesses are slices (bounds-checked)
//! and the table rows of `lookup`, whose indices are clamped into the table.

use crate::table::SINCOSTAB;
use std::arch::x86_64::*;

const SIGN: f64 = -0.0;
const BIG: f64 = f64::from_bits(0x42c8_0000_0000_0000); // 1.5 * 2^45
const TOINT: f64 = f64::from_bits(0x4338_0000_0000_0000); // 1.5 * 2^52
const HPINV: f64 = f64::from_bits(0x3fe4_5f30_6dc9_c883); // 2/pi
const HP0: f64 = f64::from_bits(0x3ff9_21fb_5444_2d18); // pi/2, high
const HP1: f64 = f64::from_bits(0x3c91_a626_3314_5c07); // pi/2, low
const MP1: f64 = f64::from_bits(0x3ff9_21fb_5800_0000);
const MP2: f64 = f64::from_bits(0xbe4d_de97_3c00_0000);
const PP3: f64 = f64::from_bits(0xbc8c_b3b3_9800_0000);
const PP4: f64 = f64::from_bits(0xbacd_747f_23e3_2ed7);
// Taylor polynomial of sin (|a| < 0.126).
const S1: f64 = f64::from_bits(0xbfc5_5555_5555_5555);
const S2: f64 = f64::from_bits(0x3f81_1111_1111_0ece);
const S3: f64 = f64::from_bits(0xbf2a_01a0_19db_08b8);
const S4: f64 = f64::from_bits(0x3ec7_1de2_7b9a_7ed9);
const S5: f64 = f64::from_bits(0xbe5a_ddff_c2fc_df59);
// sin and cos of the small remainder beside a table point.
const SN3: f64 = f64::from_bits(0xbfc5_5555_5555_5515);
const SN5: f64 = f64::from_bits(0x3f81_1110_e829_872f);
const CS2: f64 = 0.5;
const CS4: f64 = f64::from_bits(0xbfa5_5555_5555_5535);
const CS6: f64 = f64::from_bits(0x3f56_c16b_edd9_e239);
const TAYLOR_MAX: f64 = f64::from_bits(0x3fc0_20c4_9ba5_e354); // 0.126
                                                               // Path limits on |x|: glibc compares the high word, i.e. |x| < these.
const SIN_TINY: f64 = f64::from_bits(0x3e50_0000_0000_0000); // 2^-26
const COS_TINY: f64 = f64::from_bits(0x3e40_0000_0000_0000); // 2^-27
const SMALL: f64 = f64::from_bits(0x3feb_6000_0000_0000); // 0.85546875
const MID: f64 = f64::from_bits(0x4003_68fd_0000_0000); // 2.426265...
/// Above this (and for ±inf, NaN) glibc uses `__branred`: libm's job here.
const REDUCE: f64 = f64::from_bits(0x4199_21fb_0000_0000); // 105414350.0...

type V = __m256d;

/// `v` in all four lanes.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn splat(v: f64) -> V {
    _mm256_set1_pd(v)
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn abs(v: V) -> V {
    _mm256_andnot_pd(splat(SIGN), v)
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn neg(v: V) -> V {
    _mm256_xor_pd(v, splat(SIGN))
}

/// `copysign(mag, sign)`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn copysign(mag: V, sign: V) -> V {
    let s = splat(SIGN);
    _mm256_or_pd(_mm256_andnot_pd(s, mag), _mm256_and_pd(s, sign))
}

/// `mask ? b : a` per lane.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn pick(a: V, b: V, mask: V) -> V {
    _mm256_blendv_pd(a, b, mask)
}

#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn any(mask: V) -> bool {
    _mm256_movemask_pd(mask) != 0
}

/// The table entries `[sn, ssn, cs, ccs]` at `k = low 32 bits of u`, where
/// `u = BIG + |a|`. Indices are clamped to the table (lanes that are not on
/// a table path may hold anything; valid lanes have k <= 109). Four row
/// loads and a 4x4 transpose: cheaper than four gathers.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn lookup(u: V) -> [V; 4] {
    let lo = _mm256_permutevar8x32_epi32(
        _mm256_castpd_si256(u),
        _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6),
    );
    let k = _mm256_castsi256_si128(lo);
    let k = _mm_max_epi32(_mm_min_epi32(k, _mm_set1_epi32(109)), _mm_setzero_si128());
    let mut ks = [0u32; 4];
    _mm_storeu_si128(ks.as_mut_ptr().cast(), _mm_slli_epi32::<2>(k));
    let t = SINCOSTAB.0.as_ptr();
    // SAFETY (for the caller's unsafe block): each row 4k..4k+3 <= 439 < 440.
    let r0 = _mm256_load_pd(t.add(ks[0] as usize));
    let r1 = _mm256_load_pd(t.add(ks[1] as usize));
    let r2 = _mm256_load_pd(t.add(ks[2] as usize));
    let r3 = _mm256_load_pd(t.add(ks[3] as usize));
    let t0 = _mm256_unpacklo_pd(r0, r1); // sn0 sn1 cs0 cs1
    let t1 = _mm256_unpackhi_pd(r0, r1); // ssn0 ssn1 ccs0 ccs1
    let t2 = _mm256_unpacklo_pd(r2, r3);
    let t3 = _mm256_unpackhi_pd(r2, r3);
    [
        _mm256_permute2f128_pd::<0x20>(t0, t2),
        _mm256_permute2f128_pd::<0x20>(t1, t3),
        _mm256_permute2f128_pd::<0x31>(t0, t2),
        _mm256_permute2f128_pd::<0x31>(t1, t3),
    ]
}

/// `TAYLOR_SIN(a * a, a, da)`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn taylor_sin(a: V, da: V) -> V {
    let xx = _mm256_mul_pd(a, a);
    let mut p = _mm256_fmadd_pd(xx, splat(S5), splat(S4));
    p = _mm256_fmadd_pd(xx, p, splat(S3));
    p = _mm256_fmadd_pd(xx, p, splat(S2));
    p = _mm256_fmadd_pd(xx, p, splat(S1));
    let q = _mm256_fmsub_pd(p, a, _mm256_mul_pd(da, splat(0.5)));
    _mm256_add_pd(a, _mm256_fmadd_pd(xx, q, da))
}

/// `BIG + |a|`: its low bits index the table.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn table_key(a: V) -> V {
    _mm256_add_pd(abs(a), splat(BIG))
}

/// `do_sin(a, da)` for |a| >= 0.126 (the table path); `u = table_key(a)`,
/// `rows = lookup(u)`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn sin_table(a: V, da: V, u: V, rows: [V; 4]) -> V {
    let le0 = _mm256_cmp_pd::<_CMP_LE_OQ>(a, _mm256_setzero_pd());
    let dx = pick(da, neg(da), le0);
    let ax = abs(a);
    let x = _mm256_sub_pd(ax, _mm256_sub_pd(u, splat(BIG)));
    let xx = _mm256_mul_pd(x, x);
    let p = _mm256_fmadd_pd(xx, splat(SN5), splat(SN3));
    let s = _mm256_add_pd(x, _mm256_fmadd_pd(_mm256_mul_pd(x, xx), p, dx));
    let q = _mm256_fmadd_pd(xx, _mm256_fmadd_pd(xx, splat(CS6), splat(CS4)), splat(CS2));
    let c = _mm256_fmadd_pd(x, dx, _mm256_mul_pd(xx, q));
    let [sn, ssn, cs, ccs] = rows;
    let cor = _mm256_fmadd_pd(s, cs, _mm256_fnmadd_pd(c, sn, _mm256_fmadd_pd(s, ccs, ssn)));
    copysign(_mm256_add_pd(sn, cor), a)
}

/// `do_sin(a, da)`: Taylor below 0.126, the table above (both computed:
/// a branch on the lanes' mix would be mispredicted often).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn do_sin(a: V, da: V, u: V, rows: [V; 4]) -> V {
    let taylor = _mm256_cmp_pd::<_CMP_LT_OQ>(abs(a), splat(TAYLOR_MAX));
    pick(sin_table(a, da, u, rows), taylor_sin(a, da), taylor)
}

/// `do_cos(a, da)`; `u = table_key(a)`, `rows = lookup(u)`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn do_cos(a: V, da: V, u: V, rows: [V; 4]) -> V {
    let lt0 = _mm256_cmp_pd::<_CMP_LT_OQ>(a, _mm256_setzero_pd());
    let dx = pick(da, neg(da), lt0);
    let ax = abs(a);
    let x = _mm256_add_pd(_mm256_sub_pd(ax, _mm256_sub_pd(u, splat(BIG))), dx);
    let xx = _mm256_mul_pd(x, x);
    let p = _mm256_fmadd_pd(xx, splat(SN5), splat(SN3));
    let s = _mm256_fmadd_pd(_mm256_mul_pd(x, xx), p, x);
    let q = _mm256_fmadd_pd(xx, _mm256_fmadd_pd(xx, splat(CS6), splat(CS4)), splat(CS2));
    let c = _mm256_mul_pd(xx, q);
    let [sn, ssn, cs, ccs] = rows;
    let cor = _mm256_fnmadd_pd(
        s,
        sn,
        _mm256_fnmadd_pd(c, cs, _mm256_fnmadd_pd(s, ssn, ccs)),
    );
    _mm256_add_pd(cs, cor)
}

/// `reduce_sincos(x)`: `(a, da, n)` with `a + da` = x - n pi/2 (n mod 4 as
/// the low bits of the returned integer lanes).
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn reduce(x: V) -> (V, V, __m256i) {
    let t = _mm256_fmadd_pd(x, splat(HPINV), splat(TOINT));
    let xn = _mm256_sub_pd(t, splat(TOINT));
    let y = _mm256_fnmadd_pd(xn, splat(MP1), x);
    let y = _mm256_fnmadd_pd(xn, splat(MP2), y);
    let t2 = _mm256_fnmadd_pd(xn, splat(PP3), y);
    let db = _mm256_fnmadd_pd(xn, splat(PP3), _mm256_sub_pd(y, t2));
    let b = _mm256_fnmadd_pd(xn, splat(PP4), t2);
    let db = _mm256_add_pd(db, _mm256_fnmadd_pd(xn, splat(PP4), _mm256_sub_pd(t2, b)));
    (b, db, _mm256_castpd_si256(t))
}

/// Lanes where `n & bit != 0`, as a double mask.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn bit_set(n: __m256i, bit: i64) -> V {
    let b = _mm256_set1_epi64x(bit);
    _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(n, b), b))
}

/// sin and/or cos of four lanes, and the mask (bits 0-3) of lanes left to
/// libm (|x| >= 105414350, inf, NaN), whose results here are meaningless.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn eval<const SIN: bool, const COS: bool>(x: V) -> (V, V, i32) {
    let zero = _mm256_setzero_pd();
    let ax = abs(x);
    let ok = _mm256_cmp_pd::<_CMP_LT_OQ>(ax, splat(REDUCE));
    let small = _mm256_cmp_pd::<_CMP_LT_OQ>(ax, splat(SMALL));
    let below_mid = _mm256_cmp_pd::<_CMP_LT_OQ>(ax, splat(MID));
    let mid = _mm256_andnot_pd(small, below_mid);
    let red = _mm256_andnot_pd(below_mid, ok);

    // Arguments of do_sin (sa, sda) and do_cos (ca, cda) per lane.
    let (mut sa, mut sda, mut ca, mut cda) = (x, zero, x, zero);
    let (mut sin_c, mut cos_c) = (mid, small);
    let (mut sin_neg, mut cos_neg) = (zero, zero);
    // Middle path (computed whatever the lanes: cheaper than a branch).
    // sin: do_cos(hp0 - |x|, hp1); cos: do_sin of that, split in two.
    let t = _mm256_sub_pd(splat(HP0), ax);
    ca = pick(ca, t, mid);
    cda = pick(cda, splat(HP1), mid);
    if COS {
        let a = _mm256_add_pd(t, splat(HP1));
        let da = _mm256_add_pd(_mm256_sub_pd(t, a), splat(HP1));
        sa = pick(sa, a, mid);
        sda = pick(sda, da, mid);
    }
    if any(red) {
        let (a, da, n) = reduce(x);
        sa = pick(sa, a, red);
        sda = pick(sda, da, red);
        ca = pick(ca, a, red);
        cda = pick(cda, da, red);
        let odd = _mm256_and_pd(bit_set(n, 1), red);
        sin_c = _mm256_or_pd(sin_c, odd);
        cos_c = _mm256_or_pd(cos_c, _mm256_andnot_pd(odd, red));
        sin_neg = _mm256_and_pd(bit_set(n, 2), red);
        let n1 = _mm256_add_epi64(n, _mm256_set1_epi64x(1));
        cos_neg = _mm256_and_pd(bit_set(n1, 2), red);
    }

    // Which kernels some wanted lane needs.
    let mut need_s = zero;
    let mut need_c = zero;
    if SIN {
        need_s = _mm256_or_pd(need_s, _mm256_andnot_pd(sin_c, ok));
        need_c = _mm256_or_pd(need_c, _mm256_and_pd(sin_c, ok));
    }
    if COS {
        need_s = _mm256_or_pd(need_s, _mm256_andnot_pd(cos_c, ok));
        need_c = _mm256_or_pd(need_c, _mm256_and_pd(cos_c, ok));
    }
    // One table lookup when both kernels read the same rows (the usual case
    // when both run: the same argument, or pi/2 - |x| and its split).
    let (us, uc) = (table_key(sa), table_key(ca));
    let (run_s, run_c) = (any(need_s), any(need_c));
    let (ks, kc) = match (run_s, run_c) {
        (true, false) => (do_sin(sa, sda, us, lookup(us)), zero),
        (false, true) => (zero, do_cos(ca, cda, uc, lookup(uc))),
        (false, false) => (zero, zero),
        (true, true) => {
            let rs = lookup(us);
            let same = _mm256_cmp_pd::<_CMP_EQ_OQ>(us, uc);
            let rc = if _mm256_movemask_pd(same) == 0xf {
                rs
            } else {
                lookup(uc)
            };
            (do_sin(sa, sda, us, rs), do_cos(ca, cda, uc, rc))
        }
    };

    let mut s = zero;
    if SIN {
        s = pick(ks, kc, sin_c);
        s = pick(s, copysign(s, x), mid);
        s = pick(s, neg(s), sin_neg);
        s = pick(s, x, _mm256_cmp_pd::<_CMP_LT_OQ>(ax, splat(SIN_TINY)));
    }
    let mut c = zero;
    if COS {
        c = pick(ks, kc, cos_c);
        c = pick(c, neg(c), cos_neg);
        c = pick(
            c,
            splat(1.0),
            _mm256_cmp_pd::<_CMP_LT_OQ>(ax, splat(COS_TINY)),
        );
    }
    (s, c, !_mm256_movemask_pd(ok) & 0xf)
}

/// Stores the first `n` lanes of `v` at `out[i..i + n]`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn store(out: &mut [f64], i: usize, n: usize, v: V) {
    if n == 4 {
        _mm256_storeu_pd(out[i..i + 4].as_mut_ptr(), v);
    } else {
        let mut tmp = [0.0; 4];
        _mm256_storeu_pd(tmp.as_mut_ptr(), v);
        out[i..i + n].copy_from_slice(&tmp[..n]);
    }
}

/// sin (if `SIN`) and cos (if `COS`) of every element of `x` into `sin` /
/// `cos` (the one not asked for may be empty), four lanes at a time, the
/// tail zero-padded; lanes beyond the vector range through `libm_sin` /
/// `libm_cos`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn run<const SIN: bool, const COS: bool>(
    x: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
    libm_sin: fn(f64) -> f64,
    libm_cos: fn(f64) -> f64,
) {
    assert!((!SIN || sin.len() == x.len()) && (!COS || cos.len() == x.len()));
    let mut i = 0;
    while i < x.len() {
        let n = (x.len() - i).min(4);
        let v = if n == 4 {
            _mm256_loadu_pd(x[i..i + 4].as_ptr())
        } else {
            let mut pad = [0.0; 4];
            pad[..n].copy_from_slice(&x[i..]);
            _mm256_loadu_pd(pad.as_ptr())
        };
        let (s, c, bad) = eval::<SIN, COS>(v);
        if SIN {
            store(sin, i, n, s);
        }
        if COS {
            store(cos, i, n, c);
        }
        if bad != 0 {
            for l in 0..n {
                if bad & (1 << l) != 0 {
                    if SIN {
                        sin[i + l] = libm_sin(x[i + l]);
                    }
                    if COS {
                        cos[i + l] = libm_cos(x[i + l]);
                    }
                }
            }
        }
        i += n;
    }
}

/// `out[i] = sin(x[i])`, lanes beyond the vector range through `libm_sin`.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub unsafe fn sin_lanes(x: &[f64], out: &mut [f64], libm_sin: fn(f64) -> f64) {
    run::<true, false>(x, out, &mut [], libm_sin, libm_sin);
}

/// `out[i] = cos(x[i])`, lanes beyond the vector range through `libm_cos`.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub unsafe fn cos_lanes(x: &[f64], out: &mut [f64], libm_cos: fn(f64) -> f64) {
    run::<false, true>(x, &mut [], out, libm_cos, libm_cos);
}

/// `sin[i], cos[i] = sin(x[i]), cos(x[i])` (the bits of the two functions,
/// not of glibc's `sincos`), lanes beyond the vector range through libm.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub unsafe fn sincos_lanes(
    x: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
    libm_sin: fn(f64) -> f64,
    libm_cos: fn(f64) -> f64,
) {
    run::<true, true>(x, sin, cos, libm_sin, libm_cos);
}
