//! Derived from glibc's `sysdeps/ieee754/dbl-64/s_sin.c` (IBM Accurate
//! Mathematical Library, written by International Business Machines Corp.;
//! Copyright (C) 2001-2022 Free Software Foundation, Inc.), under the GNU
//! Lesser General Public License 2.1 or (at your option) any later version:
//! see the crate's `COPYING`.
//!
//! Four lanes at a time: glibc 2.36's `__sin_fma` / `__cos_fma` (the
//! algorithm in `kernel.rs`) with AVX2+FMA intrinsics over `__m256d`.
//! Masks are whole-lane doubles (`blendv` picks), table rows are four
//! aligned loads and a transpose (cheaper than four gathers), the tail is
//! zero-padded through a small buffer.
//!
//! Every function here is `unsafe` only because it is compiled for AVX2+FMA
//! (`#[target_feature]`): calling it is sound on a CPU with both, which the
//! caller of the three entry points checks (`rwg_env::lanes_math`'s
//! `Vector`). The only memory accesses are slices (bounds-checked) and the
//! table rows of `lookup`, whose indices are clamped into the table.

use crate::kernel::{entry_points, Lanes, SIGN, TABLE_MAX_K};
use crate::table::SINCOSTAB;
use std::arch::x86_64::*;

impl Lanes for __m256d {
    const N: usize = 4;
    type M = __m256d;
    type I = __m256i;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn splat(v: f64) -> Self {
        _mm256_set1_pd(v)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn add(self, b: Self) -> Self {
        _mm256_add_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn sub(self, b: Self) -> Self {
        _mm256_sub_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn mul(self, b: Self) -> Self {
        _mm256_mul_pd(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fmadd(self, b: Self, c: Self) -> Self {
        _mm256_fmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fmsub(self, b: Self, c: Self) -> Self {
        _mm256_fmsub_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fnmadd(self, b: Self, c: Self) -> Self {
        _mm256_fnmadd_pd(self, b, c)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn abs(self) -> Self {
        _mm256_andnot_pd(_mm256_set1_pd(SIGN), self)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn neg(self) -> Self {
        _mm256_xor_pd(self, _mm256_set1_pd(SIGN))
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn copysign(self, sign: Self) -> Self {
        let s = _mm256_set1_pd(SIGN);
        _mm256_or_pd(_mm256_andnot_pd(s, self), _mm256_and_pd(s, sign))
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn lt(self, b: Self) -> Self {
        _mm256_cmp_pd::<_CMP_LT_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn le(self, b: Self) -> Self {
        _mm256_cmp_pd::<_CMP_LE_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn eq(self, b: Self) -> Self {
        _mm256_cmp_pd::<_CMP_EQ_OQ>(self, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn pick(self, b: Self, m: Self) -> Self {
        _mm256_blendv_pd(self, b, m)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn none() -> Self {
        _mm256_setzero_pd()
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn and_m(a: Self, b: Self) -> Self {
        _mm256_and_pd(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn or_m(a: Self, b: Self) -> Self {
        _mm256_or_pd(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn andnot_m(a: Self, b: Self) -> Self {
        _mm256_andnot_pd(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn bits(m: Self) -> u32 {
        _mm256_movemask_pd(m) as u32
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn to_bits(self) -> __m256i {
        _mm256_castpd_si256(self)
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn bit_set(n: __m256i, bit: i64) -> Self {
        let b = _mm256_set1_epi64x(bit);
        _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(n, b), b))
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn add_i(n: __m256i, v: i64) -> __m256i {
        _mm256_add_epi64(n, _mm256_set1_epi64x(v))
    }
    /// Four row loads and a 4x4 transpose: cheaper than four gathers.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn lookup(u: Self) -> [Self; 4] {
        let lo = _mm256_permutevar8x32_epi32(
            _mm256_castpd_si256(u),
            _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6),
        );
        let k = _mm256_castsi256_si128(lo);
        let k = _mm_max_epi32(
            _mm_min_epi32(k, _mm_set1_epi32(TABLE_MAX_K as i32)),
            _mm_setzero_si128(),
        );
        let mut ks = [0u32; 4];
        // SAFETY: `ks` is 16 writable bytes (an unaligned store).
        unsafe { _mm_storeu_si128(ks.as_mut_ptr().cast(), _mm_slli_epi32::<2>(k)) };
        let t = SINCOSTAB.0.as_ptr();
        // SAFETY: each row 4k..4k+3 <= 439 < 440 is in the table (k is
        // clamped into 0..=TABLE_MAX_K above), and the table and its rows of
        // four are 32-byte aligned.
        let (r0, r1, r2, r3) = unsafe {
            (
                _mm256_load_pd(t.add(ks[0] as usize)),
                _mm256_load_pd(t.add(ks[1] as usize)),
                _mm256_load_pd(t.add(ks[2] as usize)),
                _mm256_load_pd(t.add(ks[3] as usize)),
            )
        };
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
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load(x: &[f64]) -> Self {
        let mut pad = [0.0; 4];
        let four: &[f64] = if x.len() == 4 {
            x
        } else {
            pad[..x.len()].copy_from_slice(x);
            &pad
        };
        // SAFETY: `four` holds four readable `f64` (an unaligned load).
        unsafe { _mm256_loadu_pd(four.as_ptr()) }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store(self, out: &mut [f64]) {
        if out.len() == 4 {
            // SAFETY: `out` holds four writable `f64` (an unaligned store).
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self) };
        } else {
            let mut tmp = [0.0; 4];
            // SAFETY: as above, for `tmp`.
            unsafe { _mm256_storeu_pd(tmp.as_mut_ptr(), self) };
            out.copy_from_slice(&tmp[..out.len()]);
        }
    }
}

entry_points!(__m256d, "avx2,fma", "AVX2 and FMA");
