//! Derived from Arm's optimized-routines `math/pow.c` (Copyright (c)
//! 2018-2020, Arm Limited; MIT OR Apache-2.0 WITH LLVM-exception), the code
//! glibc's `pow` has used since 2.28; credited in THIRD-PARTY-NOTICES at the
//! repository's root.
//!
//! `pow(x, 2.0)` eight lanes at a time with AVX-512 (F, DQ, VL) intrinsics:
//! the port of glibc 2.36's `__pow_fma` in `pow_fma` (which says what it
//! computes, for which arguments, and how its roundings were matched to
//! glibc's machine code), run over `__m512d` through its [`Lanes`] trait.
//! The floating-point operations, their order and which of them are fused
//! are that module's, one source for both widths, so the bits are the same
//! as its four lanes' and glibc's. Only exact steps differ: `(double) k`
//! is one conversion (`vcvtqq2pd`, AVX-512DQ) after an arithmetic shift,
//! the tables are read with gathers, lane masks are mask registers, and a
//! slice's last `len % 8` elements go through the same code with masked
//! loads and stores.
//!
//! The entry points [`pow2_lanes`] and [`pow2_port_lanes`] are `Vector`'s
//! at the AVX-512 level.
//!
//! Every function is `unsafe` only because it is compiled for AVX-512F,
//! DQ and VL with AVX2 and FMA (`#[target_feature]`): calling it is sound
//! on a CPU with all of them (`crate::simd::Simd::Avx512`). Gathers read
//! at indices masked into the tables, whatever a lane holds; masked loads
//! and stores touch only the slice's elements.

use super::pow_fma::{in_range, pow2, slow_lanes, square_fast, Lanes};
use super::pow_table::{EXP_TAB, LOG_TAB};
use std::arch::x86_64::*;

type V8 = __m512d;
type I8 = __m512i;

impl Lanes for V8 {
    type I = I8;
    type M = __mmask8;

    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn splat(v: f64) -> V8 {
        _mm512_set1_pd(v)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn splat_i(v: i64) -> I8 {
        _mm512_set1_epi64(v)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn add(self, b: V8) -> V8 {
        _mm512_add_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn sub(self, b: V8) -> V8 {
        _mm512_sub_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn mul(self, b: V8) -> V8 {
        _mm512_mul_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn fmadd(self, b: V8, c: V8) -> V8 {
        _mm512_fmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn fmsub(self, b: V8, c: V8) -> V8 {
        _mm512_fmsub_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn abs(self) -> V8 {
        _mm512_andnot_pd(_mm512_set1_pd(-0.0), self)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn to_bits(self) -> I8 {
        _mm512_castpd_si512(self)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn from_bits(i: I8) -> V8 {
        _mm512_castsi512_pd(i)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn add_i(a: I8, b: I8) -> I8 {
        _mm512_add_epi64(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn sub_i(a: I8, b: I8) -> I8 {
        _mm512_sub_epi64(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn and_i(a: I8, b: I8) -> I8 {
        _mm512_and_si512(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn shr45(a: I8) -> I8 {
        _mm512_srli_epi64::<45>(a)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn shl45(a: I8) -> I8 {
        _mm512_slli_epi64::<45>(a)
    }
    /// An arithmetic shift and one conversion, exact for |k| < 2^53.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn top12(a: I8) -> V8 {
        _mm512_cvtepi64_pd(_mm512_srai_epi64::<52>(a))
    }
    /// Three gathers from the rows `[invc, logc, logctail, 0]`.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn log_rows(i: I8) -> [V8; 3] {
        let t: *const f64 = LOG_TAB.0.as_ptr().cast();
        let row = _mm512_slli_epi64::<2>(_mm512_and_si512(i, _mm512_set1_epi64(127)));
        let col = |j: i64| _mm512_add_epi64(row, _mm512_set1_epi64(j));
        // SAFETY: with `i & 127`, every index 4i + 2 < 512 is in the table.
        unsafe {
            [
                _mm512_i64gather_pd::<8>(row, t),
                _mm512_i64gather_pd::<8>(col(1), t),
                _mm512_i64gather_pd::<8>(col(2), t),
            ]
        }
    }
    /// Two gathers from the pairs `[tail, sbits]`.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn exp_pairs(k: I8) -> (V8, V8) {
        let t: *const f64 = EXP_TAB.as_ptr().cast();
        let pair = _mm512_slli_epi64::<1>(_mm512_and_si512(k, _mm512_set1_epi64(127)));
        let tail = _mm512_add_epi64(pair, _mm512_set1_epi64(1));
        // SAFETY: with `k & 127`, every index 2k + 1 < 256 is in the table.
        unsafe {
            (
                _mm512_i64gather_pd::<8>(pair, t),
                _mm512_i64gather_pd::<8>(tail, t),
            )
        }
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn ge(a: V8, b: V8) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_GE_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn le(a: V8, b: V8) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_LE_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn eq(a: V8, b: V8) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn and_m(a: __mmask8, b: __mmask8) -> __mmask8 {
        a & b
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn andnot_m(a: __mmask8, b: __mmask8) -> __mmask8 {
        !a & b
    }
}

/// The mask of the first `n` of eight lanes (`n` in 1..=8).
#[inline(always)]
fn first(n: usize) -> __mmask8 {
    (0xffu16 >> (8 - n)) as __mmask8
}

/// `out[i] = pow(x[i], 2)` with libm's bits: the fast path where it settles
/// the result, the port for the other lanes in its range (a group of eight
/// with no such lane skips it), `slow` (`pow2`) for the rest. The slices
/// must have equal lengths (panics otherwise).
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
pub(super) unsafe fn pow2_lanes(x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    assert_eq!(x.len(), out.len(), "pow2_lanes: arguments and results");
    for start in (0..x.len()).step_by(8) {
        let end = x.len().min(start + 8);
        let live = first(end - start);
        // SAFETY (of each block of this loop): `end <= len` for both
        // slices, and the masked load and stores touch only the live lanes,
        // `start..end`; the CPU has AVX-512F/DQ/VL with AVX2 and FMA (this
        // function's precondition), what the kernels need.
        let (px, po) = unsafe { (x.as_ptr().add(start), out.as_mut_ptr().add(start)) };
        let v = unsafe { _mm512_maskz_loadu_pd(live, px) };
        let (p, fast) = unsafe { square_fast(v) };
        if fast & live == live {
            unsafe { _mm512_mask_storeu_pd(po, live, p) };
            continue;
        }
        let (port, q) = unsafe { (in_range(v), pow2(v)) };
        unsafe { _mm512_mask_storeu_pd(po, live, _mm512_mask_blend_pd(fast, q, p)) };
        let libm = live & !(fast | port);
        slow_lanes(libm.into(), &x[start..end], &mut out[start..end], slow);
    }
}

/// The port alone for every lane in its range (libm `slow` for the rest),
/// without the fast path: what `rwg bench libm --check` compares with libm.
/// The slices must have equal lengths (panics otherwise).
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
pub(super) unsafe fn pow2_port_lanes(x: &[f64], out: &mut [f64], slow: fn(f64) -> f64) {
    assert_eq!(x.len(), out.len(), "pow2_port_lanes: arguments and results");
    for start in (0..x.len()).step_by(8) {
        let end = x.len().min(start + 8);
        let live = first(end - start);
        // SAFETY (of each block of this loop): as in `pow2_lanes`.
        let (px, po) = unsafe { (x.as_ptr().add(start), out.as_mut_ptr().add(start)) };
        let v = unsafe { _mm512_maskz_loadu_pd(live, px) };
        let (q, inside) = unsafe { (pow2(v), in_range(v)) };
        unsafe { _mm512_mask_storeu_pd(po, live, q) };
        let outside = live & !inside;
        slow_lanes(outside.into(), &x[start..end], &mut out[start..end], slow);
    }
}
