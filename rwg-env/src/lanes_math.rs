//! glibc's `sin`, `cos` and `pow(x, 2)` over many arguments at once, for
//! environments stepped in lockstep over lanes (structure of arrays).
//!
//! Contract: every output is bit for bit what this process's libm `sin` /
//! `cos` / `pow` (glibc on Linux) returns for the same argument, whatever
//! runs underneath. Gymnasium computes these with Python's `math.sin` /
//! `math.cos` (two separate glibc calls), so the envs' trajectories depend on
//! exactly these bits. [`sincos_lanes`] returns the bits of `sin` and of
//! `cos`, never those of glibc's `sincos`, which differs from `sin` at rare
//! arguments (glibc 2.36: `sin(0x1.ad1fb54442d18p+0)` is one ulp above
//! `sincos`'s sine). Beware that LLVM turns `x.sin()` and `x.cos()` of one
//! `x` in one function into a `sincos` call; the scalar paths here call
//! `sin` and `cos` through functions it cannot merge. Slices must have equal
//! lengths (panics otherwise).
//!
//! # Implementations
//!
//! Three levels, the ones of [`crate::simd`]: [`simd::level`] picks one
//! for the process (`RWG_SIMD=avx512|avx2|scalar`, unset: the CPU's
//! widest), and each function runs it if its self-check passed there.
//!
//! - **AVX-512** ([`Simd::Avx512`], eight lanes) and **AVX2** ([`Simd::Avx2`],
//!   four lanes), x86-64 only: for `sin`/`cos`, a port of glibc 2.36's
//!   `__sin_fma`/`__cos_fma` for |x| < 105414350 (the crate
//!   `rwg-glibc-sincos`, LGPL-2.1-or-later, present only with this crate's
//!   `glibc-sincos` feature: see below; one algorithm at both widths);
//!   lanes beyond (huge, ±inf, NaN) call libm. [`pow2_lanes`] settles most
//!   squares with [`crate::float::pow2`]'s fast path (`x*x` when the exact
//!   square is within 0.48 ulp of it) and computes the rest (about 4 %) with
//!   a port of glibc 2.36's `__pow_fma` for `y = 2` (modules `pow_fma`, four
//!   lanes, and `pow_avx512`, eight; 2^-60 <= |x| <= 2^32); other lanes
//!   call libm. A level runs when (a) the CPU has it (AVX2 and FMA, the
//!   condition under which glibc's ifunc selects those variants; AVX-512F,
//!   DQ and VL besides for eight lanes) and (b) a one-time self-check of
//!   that level's code gives this process's libm bits on all of its
//!   arguments: [`edge_arguments`] for `sin`/`cos` (every path, every path
//!   boundary, the table's rounding points, the reduction's hard cases: a
//!   few thousand arguments), [`pow2_edge_arguments`] for `pow`, so either
//!   port can run without the other. Another glibc version, another libm
//!   (musl, macOS) or a CPU without FMA fails (a) or (b) and gets the
//!   scalar loop (never the other vector level), so the contract holds
//!   everywhere; only the speed differs.
//! - **Scalar** ([`Simd::Scalar`]): one libm call per element (for `pow`,
//!   [`crate::float::pow2`] per element). Forced with `RWG_SIMD=scalar`
//!   (e.g. for benchmarks).
//!
//! [`implementation`] (sin/cos) and [`pow_implementation`] say which one
//! runs and why; [`implementation_at`] and [`pow_implementation_at`] decide
//! for any level (each level's self-check runs once, when first asked).
//! `rwg bench libm --check N` compares every vector level the CPU has with
//! libm over N arguments on the user's machine.
//!
//! # The `glibc-sincos` feature
//!
//! The vector `sin`/`cos` follows glibc's `s_sin.c` and `sincostab.c`
//! (originally IBM's Accurate Mathematical Library), which are
//! LGPL-2.1-or-later, so it lives in the crate `rwg-glibc-sincos` under that
//! licence, and this crate (MIT OR Apache-2.0) uses it only with its
//! feature `glibc-sincos`, off by default: a plugin depending on `rwg-env`
//! contains no LGPL code. Without the feature [`SIN_COS_BUILT_IN`] is false,
//! [`implementation`] is `Scalar(NotBuiltIn)` and the `sin`/`cos` functions
//! (also [`Vector`]'s) call libm once per element: the same bits, more
//! slowly. The `rwg` binary and the reference plugin turn it on.
//!
//! The vector `pow(x, 2)` (modules `pow_fma`, `pow_avx512`, `pow_table`)
//! is not affected: it follows Arm's optimized-routines `pow` (MIT OR
//! Apache-2.0 WITH LLVM-exception), which glibc adopted in 2.28.

#[cfg(target_arch = "x86_64")]
mod pow_avx512;
#[cfg(all(test, target_arch = "x86_64"))]
mod pow_avx512_tests;
mod pow_edges;
#[cfg(target_arch = "x86_64")]
mod pow_fma;
#[cfg(target_arch = "x86_64")]
mod pow_table;
#[cfg(test)]
mod pow_tests;
#[cfg(test)]
mod tests;

use crate::float::{libm_cos, libm_sin};
use crate::simd::{self, Simd};
use std::sync::OnceLock;

/// Whether this build has the vector `sin`/`cos` (the `glibc-sincos`
/// feature); without it every `sin`/`cos` here is one libm call per
/// element. (With it, the vector code still needs an x86-64 CPU with AVX2
/// and FMA, or AVX-512 for eight lanes: [`implementation`].)
pub const SIN_COS_BUILT_IN: bool = cfg!(feature = "glibc-sincos");

/// One libm call per element: the reference the vector code must match.
pub mod scalar {
    use super::{libm_cos, libm_sin};

    /// `out[i] = sin(x[i])` by libm.
    pub fn sin_lanes(x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "sin_lanes: arguments and results");
        for (o, &v) in out.iter_mut().zip(x) {
            *o = libm_sin(v);
        }
    }

    /// `out[i] = cos(x[i])` by libm.
    pub fn cos_lanes(x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "cos_lanes: arguments and results");
        for (o, &v) in out.iter_mut().zip(x) {
            *o = libm_cos(v);
        }
    }

    /// `sin[i] = sin(x[i])`, `cos[i] = cos(x[i])` by libm's `sin` and `cos`.
    pub fn sincos_lanes(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
        assert_eq!(x.len(), sin.len(), "sincos_lanes: arguments and sines");
        assert_eq!(x.len(), cos.len(), "sincos_lanes: arguments and cosines");
        for ((s, c), &v) in sin.iter_mut().zip(cos.iter_mut()).zip(x) {
            *s = libm_sin(v);
            *c = libm_cos(v);
        }
    }

    /// `out[i] = pow(x[i], 2)` by libm.
    pub fn pow2_lanes(x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "pow2_lanes: arguments and results");
        for (o, &v) in out.iter_mut().zip(x) {
            *o = crate::float::pow2_libm(v);
        }
    }
}

/// The vector implementation at one level ([`Simd::Avx2`]: four lanes,
/// [`Simd::Avx512`]: eight), available only on a CPU that has that level
/// (holding a `Vector` proves it). Whether its bits are this process's
/// libm's is what the self-check (and `rwg bench libm --check`) tests:
/// [`sin_lanes`] & co. use it only when that passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Vector {
    level: Simd,
}

impl Vector {
    /// The vector code at `level`: `Some` for [`Simd::Avx2`] or
    /// [`Simd::Avx512`] on a CPU that has that level, `None` for
    /// [`Simd::Scalar`] or a level the CPU lacks.
    pub fn at(level: Simd) -> Option<Vector> {
        (level != Simd::Scalar && level.available()).then_some(Vector { level })
    }

    /// The vector code at every level this CPU has, narrowest first (for
    /// checks and benchmarks that compare them).
    pub fn all() -> Vec<Vector> {
        Simd::available_levels()
            .into_iter()
            .filter_map(Vector::at)
            .collect()
    }

    /// Its level ([`Simd::Avx2`] or [`Simd::Avx512`]).
    pub fn level(self) -> Simd {
        self.level
    }

    /// `f64` lanes per vector: 4 or 8.
    pub fn lanes(self) -> usize {
        match self.level {
            Simd::Avx512 => 8,
            _ => 4,
        }
    }

    /// The instruction set and width, e.g. "AVX-512, 8 lanes".
    pub fn name(self) -> &'static str {
        match self.level {
            Simd::Avx512 => "AVX-512, 8 lanes",
            _ => "AVX2+FMA, 4 lanes",
        }
    }

    /// `out[i] = sin(x[i])`, [`Vector::lanes`] lanes at a time (one libm
    /// call per element without [`SIN_COS_BUILT_IN`]).
    pub fn sin_lanes(self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "sin_lanes: arguments and results");
        #[cfg(all(feature = "glibc-sincos", target_arch = "x86_64"))]
        // SAFETY: `self` exists only if the CPU has its level (`at`).
        unsafe {
            match self.level {
                Simd::Avx512 => rwg_glibc_sincos::avx512::sin_lanes(x, out, libm_sin),
                _ => rwg_glibc_sincos::sin_lanes(x, out, libm_sin),
            }
        }
        #[cfg(not(all(feature = "glibc-sincos", target_arch = "x86_64")))]
        scalar::sin_lanes(x, out)
    }

    /// `out[i] = cos(x[i])`, [`Vector::lanes`] lanes at a time (one libm
    /// call per element without [`SIN_COS_BUILT_IN`]).
    pub fn cos_lanes(self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "cos_lanes: arguments and results");
        #[cfg(all(feature = "glibc-sincos", target_arch = "x86_64"))]
        // SAFETY: `self` exists only if the CPU has its level (`at`).
        unsafe {
            match self.level {
                Simd::Avx512 => rwg_glibc_sincos::avx512::cos_lanes(x, out, libm_cos),
                _ => rwg_glibc_sincos::cos_lanes(x, out, libm_cos),
            }
        }
        #[cfg(not(all(feature = "glibc-sincos", target_arch = "x86_64")))]
        scalar::cos_lanes(x, out)
    }

    /// `sin[i], cos[i] = sin(x[i]), cos(x[i])`, [`Vector::lanes`] lanes at a
    /// time (one libm `sin` and one `cos` call per element without
    /// [`SIN_COS_BUILT_IN`]).
    pub fn sincos_lanes(self, x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
        assert_eq!(x.len(), sin.len(), "sincos_lanes: arguments and sines");
        assert_eq!(x.len(), cos.len(), "sincos_lanes: arguments and cosines");
        #[cfg(all(feature = "glibc-sincos", target_arch = "x86_64"))]
        // SAFETY: `self` exists only if the CPU has its level (`at`).
        unsafe {
            use rwg_glibc_sincos::avx512;
            match self.level {
                Simd::Avx512 => avx512::sincos_lanes(x, sin, cos, libm_sin, libm_cos),
                _ => rwg_glibc_sincos::sincos_lanes(x, sin, cos, libm_sin, libm_cos),
            }
        }
        #[cfg(not(all(feature = "glibc-sincos", target_arch = "x86_64")))]
        scalar::sincos_lanes(x, sin, cos)
    }

    /// `out[i] = pow(x[i], 2)`: the fast path [`Vector::lanes`] lanes at a
    /// time, the port of `__pow_fma` for the lanes it leaves.
    pub fn pow2_lanes(self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "pow2_lanes: arguments and results");
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `self` exists only if the CPU has its level (`at`).
        unsafe {
            match self.level {
                Simd::Avx512 => pow_avx512::pow2_lanes(x, out, crate::float::pow2),
                _ => pow_fma::pow2_lanes(x, out, crate::float::pow2),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        pow2_each(x, out)
    }

    /// `out[i] = pow(x[i], 2)` by the port of `__pow_fma` alone, for every
    /// lane in its range (2^-60 <= |x| <= 2^32, |x| != 1; libm elsewhere),
    /// without [`Vector::pow2_lanes`]' fast path: the kernel that
    /// `rwg bench libm --check` compares with libm on every argument.
    pub fn pow2_port_lanes(self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), out.len(), "pow2_port_lanes: arguments and results");
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `self` exists only if the CPU has its level (`at`).
        unsafe {
            let libm = crate::float::pow2_libm;
            match self.level {
                Simd::Avx512 => pow_avx512::pow2_port_lanes(x, out, libm),
                _ => pow_fma::pow2_port_lanes(x, out, libm),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        scalar::pow2_lanes(x, out)
    }

    /// The first argument of `x` where this implementation's `pow(x, 2)`
    /// (through [`Vector::pow2_lanes`] or the port alone) differs from
    /// libm's, if any.
    pub fn first_pow2_mismatch(self, x: &[f64]) -> Option<f64> {
        let n = x.len();
        let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
        self.pow2_lanes(x, &mut a);
        self.pow2_port_lanes(x, &mut b);
        (0..n)
            .find(|&i| {
                let want = crate::float::pow2_libm(x[i]).to_bits();
                a[i].to_bits() != want || b[i].to_bits() != want
            })
            .map(|i| x[i])
    }

    /// The first argument of `x` where this implementation's `sin` or `cos`
    /// (alone or through `sincos_lanes`) differs from libm's, if any.
    pub fn first_mismatch(self, x: &[f64]) -> Option<f64> {
        let n = x.len();
        let (mut s, mut c, mut s2, mut c2) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        self.sin_lanes(x, &mut s);
        self.cos_lanes(x, &mut c);
        self.sincos_lanes(x, &mut s2, &mut c2);
        (0..n)
            .find(|&i| {
                let (ws, wc) = (libm_sin(x[i]).to_bits(), libm_cos(x[i]).to_bits());
                s[i].to_bits() != ws
                    || s2[i].to_bits() != ws
                    || c[i].to_bits() != wc
                    || c2[i].to_bits() != wc
            })
            .map(|i| x[i])
    }
}

/// Which implementation [`sin_lanes`], [`cos_lanes`] and [`sincos_lanes`]
/// ([`implementation`]) or [`pow2_lanes`] ([`pow_implementation`]) use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Implementation {
    /// The vector code at this level ([`Simd::Avx2`] or [`Simd::Avx512`]):
    /// the CPU has it and that level's self-check passed.
    Vector(Simd),
    /// One libm call per element, for the reason given.
    Scalar(ScalarReason),
}

/// Why the scalar loop runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScalarReason {
    /// `RWG_SIMD=scalar` was set.
    Forced,
    /// The CPU lacks this level (x86-64 with AVX2 and FMA for
    /// [`Simd::Avx2`], or also AVX-512F, DQ and VL for [`Simd::Avx512`]).
    NoCpuSupport(Simd),
    /// The vector `sin`/`cos` is not in this build (the `glibc-sincos`
    /// feature is off: [`SIN_COS_BUILT_IN`]).
    NotBuiltIn,
    /// The self-check of this level's vector code found an argument (this
    /// one) where its bits for this function (`"sin/cos"` or `"pow"`)
    /// differ from this process's libm (another glibc or libm).
    SelfCheckFailed(Simd, &'static str, f64),
}

impl std::fmt::Display for Implementation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = |level| Vector { level }.name();
        match *self {
            Implementation::Vector(level) => write!(
                f,
                "vector ({}, glibc 2.36's bits, self-check passed)",
                name(level)
            ),
            Implementation::Scalar(ScalarReason::Forced) => {
                write!(f, "scalar ({}=scalar)", simd::VAR)
            }
            Implementation::Scalar(ScalarReason::NoCpuSupport(Simd::Avx512)) => {
                write!(f, "scalar (no AVX-512F, DQ and VL on this CPU)")
            }
            Implementation::Scalar(ScalarReason::NoCpuSupport(_)) => {
                write!(f, "scalar (no x86-64 CPU with AVX2 and FMA)")
            }
            Implementation::Scalar(ScalarReason::NotBuiltIn) => write!(
                f,
                "scalar (vector sin/cos not built in: rwg-env's glibc-sincos feature is off)"
            ),
            Implementation::Scalar(ScalarReason::SelfCheckFailed(level, function, x)) => write!(
                f,
                "scalar (the vector {function} ({}) differs from this libm at x = {x:e} = {:#018x})",
                name(level),
                x.to_bits()
            ),
        }
    }
}

/// The implementation [`sin_lanes`], [`cos_lanes`] and [`sincos_lanes`] use:
/// [`implementation_at`] the level [`simd::level`] picks (`RWG_SIMD`, else
/// [`simd::Simd::default_level`]).
pub fn implementation() -> Implementation {
    implementation_at(simd::level())
}

/// The implementation of `sin`/`cos` at `level`, decided once per process
/// and level: the vector code of that level if the CPU has it and its
/// self-check on [`edge_arguments`] passes, else scalar (always scalar
/// without [`SIN_COS_BUILT_IN`]).
pub fn implementation_at(level: Simd) -> Implementation {
    static CHOICE: [OnceLock<Implementation>; 3] = [const { OnceLock::new() }; 3];
    *CHOICE[level as usize].get_or_init(|| {
        if !SIN_COS_BUILT_IN {
            return Implementation::Scalar(ScalarReason::NotBuiltIn);
        }
        decide(level, |v| {
            v.first_mismatch(&edge_arguments()).map(|x| ("sin/cos", x))
        })
    })
}

/// The implementation [`pow2_lanes`] uses: [`pow_implementation_at`] the
/// level [`simd::level`] picks. Its self-check is apart from
/// [`implementation`]'s: a libm whose `pow` the port does not match keeps
/// the vector `sin`/`cos` if those match, and the other way round.
pub fn pow_implementation() -> Implementation {
    pow_implementation_at(simd::level())
}

/// The implementation of `pow(x, 2)` at `level`, decided once per process
/// and level (the self-check on [`pow2_edge_arguments`]).
pub fn pow_implementation_at(level: Simd) -> Implementation {
    static CHOICE: [OnceLock<Implementation>; 3] = [const { OnceLock::new() }; 3];
    *CHOICE[level as usize].get_or_init(|| {
        decide(level, |v| {
            v.first_pow2_mismatch(&pow2_edge_arguments())
                .map(|x| ("pow", x))
        })
    })
}

/// The CPU, then `mismatch` (the self-check: the function and the first
/// argument where the vector code at `level` is not libm). `level` scalar
/// is `RWG_SIMD=scalar` on a CPU with a vector level.
fn decide(
    level: Simd,
    mismatch: impl FnOnce(Vector) -> Option<(&'static str, f64)>,
) -> Implementation {
    let Some(v) = Vector::at(level) else {
        return Implementation::Scalar(if level == Simd::Scalar && Simd::cpu() > Simd::Scalar {
            ScalarReason::Forced
        } else {
            ScalarReason::NoCpuSupport(level.max(Simd::Avx2))
        });
    };
    match mismatch(v) {
        None => Implementation::Vector(level),
        Some((function, x)) => {
            Implementation::Scalar(ScalarReason::SelfCheckFailed(level, function, x))
        }
    }
}

/// The vector code for `choice`, if that is what runs.
#[inline]
fn vector(choice: Implementation) -> Option<Vector> {
    match choice {
        // Only `decide` returns `Vector(level)`, after `Vector::at(level)`.
        Implementation::Vector(level) => Some(Vector { level }),
        Implementation::Scalar(_) => None,
    }
}

/// `out[i] = sin(x[i])` for every `i`.
pub fn sin_lanes(x: &[f64], out: &mut [f64]) {
    match vector(implementation()) {
        Some(v) => v.sin_lanes(x, out),
        None => scalar::sin_lanes(x, out),
    }
}

/// `out[i] = cos(x[i])` for every `i`.
pub fn cos_lanes(x: &[f64], out: &mut [f64]) {
    match vector(implementation()) {
        Some(v) => v.cos_lanes(x, out),
        None => scalar::cos_lanes(x, out),
    }
}

/// `sin[i] = sin(x[i])` and `cos[i] = cos(x[i])` for every `i`: the bits of
/// libm's `sin` and `cos` (see the module docs on `sincos`).
pub fn sincos_lanes(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    match vector(implementation()) {
        Some(v) => v.sincos_lanes(x, sin, cos),
        None => scalar::sincos_lanes(x, sin, cos),
    }
}

/// `out[i] = pow(x[i], 2)` (Python's `x[i]**2`) for every `i`: libm's bits.
/// Without the vector code, [`crate::float::pow2`] per element.
pub fn pow2_lanes(x: &[f64], out: &mut [f64]) {
    match vector(pow_implementation()) {
        Some(v) => v.pow2_lanes(x, out),
        None => {
            assert_eq!(x.len(), out.len(), "pow2_lanes: arguments and results");
            pow2_each(x, out)
        }
    }
}

/// [`crate::float::pow2`] (its fast path, else libm) per element: `pow2_lanes`
/// without the vector code.
fn pow2_each(x: &[f64], out: &mut [f64]) {
    for (o, &v) in out.iter_mut().zip(x) {
        *o = crate::float::pow2(v);
    }
}

/// About fourteen thousand arguments for the self-check of `pow(x, 2)`: ±0,
/// subnormals, huge, ±inf, NaN, 1 and the port's ends within a few ulps,
/// powers of two, the edges of the log table's 128 subintervals at seven
/// exponents, arguments where the exp table's index rounds, 1500 squares
/// only `pow` settles (more than 0.48 ulp from `x*x`) and 1500 log-uniform
/// over the port's range 2^-60 to 2^32; all with both signs.
pub fn pow2_edge_arguments() -> Vec<f64> {
    pow_edges::arguments()
}

/// A few thousand arguments that exercise every path of glibc's `sin` and
/// `cos` and their boundaries (the self-check's set): ±0, subnormals, each
/// path limit and 0.126 within ±8 ulps, the table's rounding points k/128 +
/// 1/256 within ±2 ulps (also as pi/2 minus them, the middle path's), the
/// doubles nearest to multiples of pi/2 (reduced arguments near 0), ±inf,
/// NaN, huge values, and log-uniform pseudo-random arguments over 1e-9 to
/// 2e8; all with both signs.
pub fn edge_arguments() -> Vec<f64> {
    let mut v: Vec<f64> = vec![
        0.0,
        f64::from_bits(1),
        f64::from_bits(0x000f_ffff_ffff_ffff),
        f64::MIN_POSITIVE,
        1e-300,
        1e300,
        f64::MAX,
        f64::INFINITY,
        f64::NAN,
        2e8,
        std::f64::consts::FRAC_PI_2,
        std::f64::consts::PI,
        std::f64::consts::TAU,
    ];
    let near = |v: &mut Vec<f64>, x: f64, ulps: i64| {
        for d in -ulps..=ulps {
            v.push(f64::from_bits((x.to_bits() as i64 + d) as u64));
        }
    };
    for limit in [
        0x3e50_0000_0000_0000u64, // sin: x
        0x3e40_0000_0000_0000,    // cos: 1
        0x3fc0_20c4_9ba5_e354,    // 0.126: Taylor / table
        0x3feb_6000_0000_0000,    // small / middle
        0x4003_68fd_0000_0000,    // middle / reduction
        0x4199_21fb_0000_0000,    // reduction / __branred
    ] {
        near(&mut v, f64::from_bits(limit), 8);
    }
    let hp0 = f64::from_bits(0x3ff9_21fb_5444_2d18);
    for k in 0..110 {
        let m = (k as f64 + 0.5) / 128.0;
        near(&mut v, m, 2);
        if hp0 - m > 0.855 {
            near(&mut v, hp0 - m, 2);
        }
        near(&mut v, hp0 + m, 2);
    }
    // Doubles nearest to n pi/2: reduced arguments close to zero.
    let mut n = 1.0;
    while n < 6.0e7 {
        near(&mut v, n * hp0, 1);
        n = (n * 1.37f64).ceil();
    }
    // Log-uniform over [1e-9, 2e8], deterministic.
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
    for _ in 0..1500 {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let u = (s >> 11) as f64 / (1u64 << 53) as f64;
        v.push((u * (2e8f64 / 1e-9).ln()).exp() * 1e-9);
    }
    let neg: Vec<f64> = v.iter().map(|x| -x).collect();
    v.extend(neg);
    v
}
