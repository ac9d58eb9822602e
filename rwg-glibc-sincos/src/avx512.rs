//! Derived from glibc's `sysdeps/ieee754/dbl-64/s_sin.c` (IBM Accurate
//! Mathematical Library, written by International Business Machines Corp.;
//! Copyright (C) 2001-2022 Free Software Foundation, Inc.), under the GNU
//! Lesser General Public License 2.1 or (at your option) any later version:
//! see the crate's `COPYING`.
//!
//! Eight lanes at a time: glibc 2.36's `__sin_fma` / `__cos_fma` with
//! AVX-512 intrinsics over `__m512d`, the same operations in the same order,
//! fused at the same places as the four-lane code (both are the one
//! algorithm of the crate's `kernel.rs`), so the same bits. Only what is
//! not floating-point arithmetic differs: comparisons give `__mmask8` masks
//! and picks are masked blends, the table is read with four gathers, and a
//! tail shorter than eight lanes is a masked load and masked stores.
//!
//! The entry points are `unsafe` only because they are compiled for
//! AVX-512F, DQ and VL (with AVX2 and FMA): calling them is sound on a CPU
//! with all of these, which the caller checks (`rwg_env::lanes_math`'s
//! `Vector`, at `rwg_env::simd::Simd::Avx512`). The only memory accesses
//! are masked loads and stores of at most a slice's length, and the table
//! gathers, whose indices are clamped into the table.

use crate::kernel::{entry_points, Lanes, SIGN, TABLE_MAX_K};
use crate::table::SINCOSTAB;
use std::arch::x86_64::*;

/// Lanes `0..n` (`n <= 8`).
#[inline]
fn first(n: usize) -> __mmask8 {
    debug_assert!(n <= 8);
    ((1u32 << n) - 1) as __mmask8
}

impl Lanes for __m512d {
    const N: usize = 8;
    type M = __mmask8;
    type I = __m512i;

    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn splat(v: f64) -> Self {
        _mm512_set1_pd(v)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn add(self, b: Self) -> Self {
        _mm512_add_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn sub(self, b: Self) -> Self {
        _mm512_sub_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn mul(self, b: Self) -> Self {
        _mm512_mul_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn fmadd(self, b: Self, c: Self) -> Self {
        _mm512_fmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn fmsub(self, b: Self, c: Self) -> Self {
        _mm512_fmsub_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn fnmadd(self, b: Self, c: Self) -> Self {
        _mm512_fnmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn abs(self) -> Self {
        _mm512_andnot_pd(_mm512_set1_pd(SIGN), self)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn neg(self) -> Self {
        _mm512_xor_pd(self, _mm512_set1_pd(SIGN))
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn copysign(self, sign: Self) -> Self {
        let s = _mm512_set1_pd(SIGN);
        _mm512_or_pd(_mm512_andnot_pd(s, self), _mm512_and_pd(s, sign))
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn lt(self, b: Self) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn le(self, b: Self) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn eq(self, b: Self) -> __mmask8 {
        _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn pick(self, b: Self, m: __mmask8) -> Self {
        _mm512_mask_blend_pd(m, self, b)
    }
    #[inline]
    unsafe fn none() -> __mmask8 {
        0
    }
    #[inline]
    unsafe fn and_m(a: __mmask8, b: __mmask8) -> __mmask8 {
        a & b
    }
    #[inline]
    unsafe fn or_m(a: __mmask8, b: __mmask8) -> __mmask8 {
        a | b
    }
    #[inline]
    unsafe fn andnot_m(a: __mmask8, b: __mmask8) -> __mmask8 {
        !a & b
    }
    #[inline]
    unsafe fn bits(m: __mmask8) -> u32 {
        m as u32
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn to_bits(self) -> __m512i {
        _mm512_castpd_si512(self)
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn bit_set(n: __m512i, bit: i64) -> __mmask8 {
        _mm512_test_epi64_mask(n, _mm512_set1_epi64(bit))
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn add_i(n: __m512i, v: i64) -> __m512i {
        _mm512_add_epi64(n, _mm512_set1_epi64(v))
    }
    /// Four gathers, one per column of the rows `k`.
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn lookup(u: Self) -> [Self; 4] {
        let k = _mm512_and_si512(_mm512_castpd_si512(u), _mm512_set1_epi64(0xffff_ffff));
        let k = _mm512_min_epu64(k, _mm512_set1_epi64(TABLE_MAX_K));
        let row = _mm512_slli_epi64::<2>(k);
        let t = SINCOSTAB.0.as_ptr();
        // SAFETY: each index 4k + j <= 439 < 440 is in the table (k is
        // clamped into 0..=TABLE_MAX_K above).
        let col = |j: i64| unsafe {
            _mm512_i64gather_pd::<8>(_mm512_add_epi64(row, _mm512_set1_epi64(j)), t)
        };
        [col(0), col(1), col(2), col(3)]
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn load(x: &[f64]) -> Self {
        // SAFETY: lanes past `x.len()` are masked off and not read.
        unsafe { _mm512_maskz_loadu_pd(first(x.len()), x.as_ptr()) }
    }
    #[inline]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
    unsafe fn store(self, out: &mut [f64]) {
        // SAFETY: lanes past `out.len()` are masked off and not written.
        unsafe { _mm512_mask_storeu_pd(out.as_mut_ptr(), first(out.len()), self) }
    }
}

entry_points!(
    __m512d,
    "avx512f,avx512dq,avx512vl,avx2,fma",
    "AVX-512F, AVX-512DQ, AVX-512VL, AVX2 and FMA"
);
