//! Eight lanes in plain Rust, one scalar IEEE operation per lane (fused
//! products by `f64::mul_add`, rounded once): the crate's algorithm
//! (`kernel.rs`) at the AVX-512 code's width, with its `u8` masks, its
//! eight-lane tails and its table clamp, runnable on any x86-64 CPU. It
//! checks the algorithm and the loop at eight lanes where the CPU has no
//! AVX-512; the AVX-512 instructions themselves are checked by the tests
//! that run `crate::avx512` where the CPU has them.

use crate::kernel::{run, Lanes, TABLE_MAX_K};
use crate::table::SINCOSTAB;

/// Eight `f64` lanes.
#[derive(Clone, Copy)]
pub(super) struct Soft8([f64; 8]);

impl Soft8 {
    fn map(self, f: impl Fn(f64) -> f64) -> Soft8 {
        Soft8(self.0.map(f))
    }

    fn zip(self, b: Soft8, f: impl Fn(f64, f64) -> f64) -> Soft8 {
        Soft8(std::array::from_fn(|i| f(self.0[i], b.0[i])))
    }

    fn zip3(self, b: Soft8, c: Soft8, f: impl Fn(f64, f64, f64) -> f64) -> Soft8 {
        Soft8(std::array::from_fn(|i| f(self.0[i], b.0[i], c.0[i])))
    }

    fn test(self, b: Soft8, f: impl Fn(f64, f64) -> bool) -> u8 {
        (0..8).fold(0, |m, i| m | (f(self.0[i], b.0[i]) as u8) << i)
    }
}

impl Lanes for Soft8 {
    const N: usize = 8;
    type M = u8;
    type I = [i64; 8];

    unsafe fn splat(v: f64) -> Self {
        Soft8([v; 8])
    }
    unsafe fn add(self, b: Self) -> Self {
        self.zip(b, |a, b| a + b)
    }
    unsafe fn sub(self, b: Self) -> Self {
        self.zip(b, |a, b| a - b)
    }
    unsafe fn mul(self, b: Self) -> Self {
        self.zip(b, |a, b| a * b)
    }
    unsafe fn fmadd(self, b: Self, c: Self) -> Self {
        self.zip3(b, c, |a, b, c| a.mul_add(b, c))
    }
    unsafe fn fmsub(self, b: Self, c: Self) -> Self {
        self.zip3(b, c, |a, b, c| a.mul_add(b, -c))
    }
    unsafe fn fnmadd(self, b: Self, c: Self) -> Self {
        self.zip3(b, c, |a, b, c| (-a).mul_add(b, c))
    }
    unsafe fn abs(self) -> Self {
        self.map(f64::abs)
    }
    unsafe fn neg(self) -> Self {
        self.map(|a| -a)
    }
    unsafe fn copysign(self, sign: Self) -> Self {
        self.zip(sign, f64::copysign)
    }
    unsafe fn lt(self, b: Self) -> u8 {
        self.test(b, |a, b| a < b)
    }
    unsafe fn le(self, b: Self) -> u8 {
        self.test(b, |a, b| a <= b)
    }
    unsafe fn eq(self, b: Self) -> u8 {
        self.test(b, |a, b| a == b)
    }
    unsafe fn pick(self, b: Self, m: u8) -> Self {
        Soft8(std::array::from_fn(|i| {
            if m >> i & 1 == 1 {
                b.0[i]
            } else {
                self.0[i]
            }
        }))
    }
    unsafe fn none() -> u8 {
        0
    }
    unsafe fn and_m(a: u8, b: u8) -> u8 {
        a & b
    }
    unsafe fn or_m(a: u8, b: u8) -> u8 {
        a | b
    }
    unsafe fn andnot_m(a: u8, b: u8) -> u8 {
        !a & b
    }
    unsafe fn bits(m: u8) -> u32 {
        m as u32
    }
    unsafe fn to_bits(self) -> [i64; 8] {
        self.0.map(|a| a.to_bits() as i64)
    }
    unsafe fn bit_set(n: [i64; 8], bit: i64) -> u8 {
        (0..8).fold(0, |m, i| m | ((n[i] & bit != 0) as u8) << i)
    }
    unsafe fn add_i(n: [i64; 8], v: i64) -> [i64; 8] {
        n.map(|n| n.wrapping_add(v))
    }
    unsafe fn lookup(u: Self) -> [Self; 4] {
        let k =
            u.0.map(|u| ((u.to_bits() & 0xffff_ffff) as i64).min(TABLE_MAX_K) as usize);
        std::array::from_fn(|j| Soft8(k.map(|k| SINCOSTAB.0[4 * k + j])))
    }
    unsafe fn load(x: &[f64]) -> Self {
        let mut v = [0.0; 8];
        v[..x.len()].copy_from_slice(x);
        Soft8(v)
    }
    unsafe fn store(self, out: &mut [f64]) {
        let n = out.len();
        out.copy_from_slice(&self.0[..n]);
    }
}

/// `out[i] = sin(x[i])` over [`Soft8`].
pub(super) fn sin_lanes(x: &[f64], out: &mut [f64], libm_sin: fn(f64) -> f64) {
    // SAFETY: Soft8's methods are plain Rust, sound on any CPU.
    unsafe { run::<Soft8, true, false>(x, out, &mut [], libm_sin, libm_sin) }
}

/// `out[i] = cos(x[i])` over [`Soft8`].
pub(super) fn cos_lanes(x: &[f64], out: &mut [f64], libm_cos: fn(f64) -> f64) {
    // SAFETY: as for `sin_lanes`.
    unsafe { run::<Soft8, false, true>(x, &mut [], out, libm_cos, libm_cos) }
}

/// `sin[i], cos[i] = sin(x[i]), cos(x[i])` over [`Soft8`].
pub(super) fn sincos_lanes(
    x: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
    libm_sin: fn(f64) -> f64,
    libm_cos: fn(f64) -> f64,
) {
    // SAFETY: as for `sin_lanes`.
    unsafe { run::<Soft8, true, true>(x, sin, cos, libm_sin, libm_cos) }
}
