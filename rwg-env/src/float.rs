//! Float formatting and the libm details that bit-exactness with Python needs.

/// Formats a float in shortest round-trip form (Rust's `Debug`, like Python's
/// `repr`): parsing the text gives back the same `f64`. Non-finite values are
/// written `NaN`, `inf`, `-inf`.
pub fn fmt_f64(x: f64) -> String {
    format!("{x:?}")
}

/// `x**2` as Python and numpy compute it on a float64: libm `pow(x, 2.0)`.
///
/// glibc's `pow` is not correctly rounded (its documented worst case is 0.54
/// ulp), so it differs from `x*x` by one ulp for about 1 in 1200 inputs. LLVM
/// folds `pow(x, 2.0)` into `x*x`, so the exponent is hidden behind
/// [`std::hint::black_box`].
///
/// Fast path: the exact square is `x*x + e`, with the rounding error `e` of
/// the product computed exactly ([`square_error`]). Whenever `pow`'s error
/// bound leaves only one candidate within reach, that candidate is the rounded
/// product `p = x*x`, and `pow` is not called:
///
/// - in general, `|e| <= 0.4` ulp: every result within 0.54 ulp of the exact
///   value is `p` (its neighbours are at least 0.6 ulp away);
/// - for `2^-60 <= |x| <= 2^32` (every square the built-in envs take in
///   practice), `|e| <= 0.48` ulp. glibc 2.28+'s `pow` (ARM optimized-routines)
///   documents its 0.54 ulp as `ulperr_exp + 1024·ln2·relerr_log·2^53` with
///   `ulperr_exp` = 0.509 ulp (0.511 without FMA), of which 0.5 is the final
///   rounding, and `relerr_log` <= 1.5·2^-68. For `|2·ln x| <= 45` the error
///   before the final rounding is therefore below 0.011 + 45·1.5·2^-15 <
///   0.013 ulp, so an exact value within 0.48 ulp of `p` rounds to `p`.
///   Measured on glibc 2.36: over 4·10^7 squares with 0.4 < |e| <= 0.5 ulp
///   (|x| from 2^-32 to 2^32), `pow` differed from `p` only for |e| > 0.4914.
///
/// Only about 4 % of inputs (those with 0.48 < |e| <= 0.5 ulp) call `pow`.
/// Over many lanes, [`crate::lanes_math::pow2_lanes`] applies the same test
/// four lanes at a time and computes those 4 % with a vector port of glibc's
/// `pow` instead.
#[inline]
pub fn pow2(x: f64) -> f64 {
    let p = x * x;
    let ax = x.abs();
    let limit = if (TIGHT_MIN..=TIGHT_MAX).contains(&ax) {
        0.48
    } else if (1e-270..1e300).contains(&p) {
        0.4
    } else {
        // Zero, tiny, huge or non-finite: no fast path (NaN lands here too).
        return pow2_libm(x);
    };
    // p >= 2^-897 here, so its ulp is normal.
    if square_error(x, p).abs() <= limit * ulp(p) {
        return p;
    }
    pow2_libm(x)
}

/// Smallest `|x|` of [`pow2`]'s 0.48-ulp fast path: `2^-60`.
pub(crate) const TIGHT_MIN: f64 = 8.673617379884035e-19;
/// Largest `|x|` of [`pow2`]'s 0.48-ulp fast path: `2^32`.
pub(crate) const TIGHT_MAX: f64 = 4294967296.0;

/// The ulp of a normal `p > 0`: 2^(exponent - 52).
#[inline(always)]
fn ulp(p: f64) -> f64 {
    f64::from_bits((p.to_bits() & 0x7ff0_0000_0000_0000).wrapping_sub(52u64 << 52))
}

/// Whether `x*x` lies more than 0.48 ulp from the exact square (for a
/// normal `x*x`): the squares [`pow2`]'s fast path leaves to `pow` for
/// 2^-60 <= |x| <= 2^32, and [`crate::lanes_math::pow2_lanes`] to its port
/// of glibc's `pow`. About 4 % of arguments.
pub fn hard_square(x: f64) -> bool {
    let p = x * x;
    square_error(x, p).abs() > 0.48 * ulp(p)
}

/// The rounding error of `p = x*x`: `x*x - p` exactly, provided
/// `2^-900 <= x*x <= 2^1000` (no partial product overflows or underflows).
///
/// With hardware FMA this is one fused multiply-add; without it (the default
/// x86-64 target, where `mul_add` is a library call), Dekker's exact product:
/// Veltkamp splitting of `x` into 26-bit halves, whose products are exact.
#[inline(always)]
pub fn square_error(x: f64, p: f64) -> f64 {
    #[cfg(target_feature = "fma")]
    {
        x.mul_add(x, -p)
    }
    #[cfg(not(target_feature = "fma"))]
    {
        const SPLIT: f64 = 134217729.0; // 2^27 + 1
        let c = SPLIT * x;
        let hi = c - (c - x);
        let lo = x - hi;
        ((hi * hi - p) + 2.0 * hi * lo) + lo * lo
    }
}

/// C's `fmod(x, d)` (Rust's `x % d`, Python's `math.fmod`): the exact
/// remainder of `x / d` truncated, with the sign of `x`; for `d > 0`.
///
/// `fmod` is exact, but the library version (a bit-by-bit long division in
/// Rust's runtime) is slow. For `|x| < 2^20 d` the result is computed here
/// as `(|x| - q d_hi) - q d_lo` with `q = trunc(|x| / d)` (corrected by one
/// when the division rounded across an integer) and `d = d_hi + d_lo`,
/// `d_hi` holding `d`'s top 26 bits: both products are exact, the first
/// subtraction is exact (its result is a multiple of ulp(|x|) below 2d), and
/// the second rounds a value that `fmod`'s exactness says is representable,
/// so it is that value. Larger or non-finite `x` and `d` that is not a
/// positive normal number go to `x % d`.
#[inline]
pub fn fmod_pos(x: f64, d: f64) -> f64 {
    let ax = x.abs();
    if !(d.is_normal() && d > 0.0 && ax < d * FMOD_FAST_QUOTIENT) {
        return x % d;
    }
    if ax < d {
        return x;
    }
    let split = split_divisor(d);
    let rem = |q: f64| fmod_rem(ax, q, split);
    let mut q = (ax / d).trunc();
    let mut r = rem(q);
    if r < 0.0 {
        q -= 1.0;
        r = rem(q);
    } else if r >= d {
        q += 1.0;
        r = rem(q);
    }
    r.copysign(x)
}

/// [`fmod_pos`] computes `|x| < FMOD_FAST_QUOTIENT * d` itself; beyond, `x % d`.
pub const FMOD_FAST_QUOTIENT: f64 = 1048576.0;

/// `d = d_hi + d_lo` with `d_hi` holding `d`'s top 26 bits, so that
/// `q * d_hi` is exact for [`fmod_pos`]'s quotients.
#[inline(always)]
pub fn split_divisor(d: f64) -> (f64, f64) {
    let d_hi = f64::from_bits(d.to_bits() & !((1u64 << 27) - 1));
    (d_hi, d - d_hi)
}

/// [`fmod_pos`]'s remainder of `ax >= 0` for the quotient `q`:
/// `(ax - q d_hi) - q d_lo` ([`split_divisor`]).
#[inline(always)]
pub fn fmod_rem(ax: f64, q: f64, (d_hi, d_lo): (f64, f64)) -> f64 {
    (ax - q * d_hi) - q * d_lo
}

/// libm `pow(x, 2.0)` without the fast path.
#[inline(never)]
pub fn pow2_libm(x: f64) -> f64 {
    x.powf(std::hint::black_box(2.0))
}

/// `u**2` as numpy computes it on a `np.float32` scalar: libm
/// `powf(u, 2.0f)`.
///
/// glibc's `powf` computes in double precision and rounds once more, so its
/// result differs now and then (about 1 in 1000 inputs) from the correctly
/// rounded `u*u`. As for [`pow2`], LLVM would fold a visible exponent of 2
/// into a multiply, so the exponent is hidden behind [`std::hint::black_box`].
/// Checked against Python's `ctypes` call of glibc 2.36 `powf` on 2 million
/// values (all bit-identical; 1900 of them differ from `u*u`).
#[inline(never)]
pub fn pow2_f32(u: f32) -> f32 {
    u.powf(std::hint::black_box(2.0f32))
}

/// Rounds to the nearest `f32` (ties to even) and widens back: numpy's
/// `float32` cast.
#[inline(always)]
pub fn f32r(x: f64) -> f64 {
    x as f32 as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow2_fast_path_matches_libm() {
        // A simple LCG over a wide range of magnitudes, including values where
        // glibc's pow and x*x differ.
        let mut s: u64 = 0x1234_5678_9abc_def0;
        let mut differing = 0;
        for _ in 0..400_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let exp = ((s >> 3) % 40) as i32 - 20;
            let x = (m * 2.0 - 1.0) * 2f64.powi(exp);
            let lib = pow2_libm(x);
            assert_eq!(pow2(x).to_bits(), lib.to_bits(), "x = {x:?}");
            differing += (lib != x * x) as u32;
        }
        // Make sure the test exercises the case that matters.
        assert!(differing > 0, "no input where pow(x,2) != x*x");
    }

    /// The 0.48-ulp band of the fast path, where `pow` is closest to
    /// rounding the other way: inputs whose squares have 0.4 < |e| <= 0.5 ulp.
    #[test]
    fn pow2_tight_band_matches_libm() {
        let mut s: u64 = 0x0123_4567_89ab_cdef;
        let (mut band, mut libm_differs) = (0, 0);
        while band < 200_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let exp = ((s >> 3) % 96) as i32 - 62; // |x| in [2^-63, 2^33)
            let x = (m * 2.0 - 1.0) * 2f64.powi(exp);
            let p = x * x;
            let ulp = f64::from_bits((p.to_bits() & 0x7ff0_0000_0000_0000) - (52u64 << 52));
            if square_error(x, p).abs() <= 0.4 * ulp {
                continue;
            }
            band += 1;
            let lib = pow2_libm(x);
            assert_eq!(pow2(x).to_bits(), lib.to_bits(), "x = {x:?}");
            libm_differs += (lib != p) as u32;
        }
        assert!(libm_differs > 0, "no input where pow(x,2) != x*x");
    }

    #[test]
    fn pow2_edge_cases() {
        for x in [
            0.0,
            -0.0,
            1e-300,
            -1e-160,
            1e160,
            1e200,
            f64::INFINITY,
            f64::MIN_POSITIVE,
        ] {
            assert_eq!(pow2(x).to_bits(), pow2_libm(x).to_bits(), "x = {x:?}");
        }
        assert!(pow2(f64::NAN).is_nan());
    }

    #[test]
    fn square_error_is_exact() {
        let mut s: u64 = 42;
        for _ in 0..100_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let exp = ((s >> 3) % 900) as i32 - 449;
            let x = (m * 2.0 - 1.0) * 2f64.powi(exp);
            let p = x * x;
            assert_eq!(square_error(x, p), x.mul_add(x, -p), "x = {x:?}");
        }
    }

    #[test]
    fn fmod_pos_is_fmod() {
        let two_pi = 2.0 * std::f64::consts::PI;
        let mut s: u64 = 77;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s
        };
        for d in [two_pi, 1.0, 0.1, 3.0, 1e-3, 7.25e10] {
            for _ in 0..200_000 {
                let r = next();
                let u = (r >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
                let x = match r % 4 {
                    0 => u * 30.0 * d,
                    1 => u * 2.0 * d,
                    2 => u * 1048576.0 * d * 1.5, // beyond the fast range too
                    _ => {
                        // Within a few ulps of a multiple of d.
                        let k = ((next() % 2000) as f64 - 1000.0) * d;
                        f64::from_bits((k.to_bits() as i64 + (next() % 9) as i64 - 4) as u64)
                    }
                };
                assert_eq!(fmod_pos(x, d).to_bits(), (x % d).to_bits(), "{x:?} % {d:?}");
            }
        }
        for x in [
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            1e300,
            -5e-324,
        ] {
            let (a, b) = (fmod_pos(x, two_pi), x % two_pi);
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{x:?}"
            );
        }
    }

    // (u, powf(u, 2.0f)) from Python: ctypes.CDLL("libm.so.6").powf(u, 2.0),
    // glibc 2.36; in each case powf differs from the correctly rounded u*u.
    #[test]
    fn pow2_f32_is_libm_powf() {
        let cases: [(u32, u32); 4] = [
            (0x40980ca6, 0x41b49e0c), // 4.751544 -> 22.577171
            (0xc035aa2a, 0x4100ea11), // -2.838511 -> 8.057145
            (0x3f979800, 0x3fb38955), // 1.1843262 -> 1.4026285
            (0xbb063800, 0x368cbd59), // -0.002048016 -> 4.194368e-6
        ];
        for (u, p) in cases {
            let u = f32::from_bits(u);
            assert_eq!(pow2_f32(u).to_bits(), p, "u = {u:?}");
            assert_ne!((u * u).to_bits(), p, "u = {u:?}: case does not test powf");
        }
        assert_eq!(pow2_f32(3.0), 9.0);
        assert!(pow2_f32(f32::NAN).is_nan());
    }

    #[test]
    fn formatting_round_trips() {
        for x in [0.1, 1.0, -2.5e-300, 1e21, 0.0499999] {
            assert_eq!(fmt_f64(x).parse::<f64>().unwrap(), x);
        }
        assert_eq!(fmt_f64(1.0), "1.0");
    }
}

/// Python's `math.sin(x)`: libm's `sin`, in a call the compiler cannot merge
/// with a `cos` of the same `x` into glibc's `sincos` (whose sine is one ulp
/// off `sin`'s at rare arguments, e.g. `0x1.ad1fb54442d18p+0`).
#[inline]
pub fn sin(x: f64) -> f64 {
    libm_sin(x)
}

/// Python's `math.cos(x)`: libm's `cos`, never merged into `sincos` (see
/// [`sin`]).
#[inline]
pub fn cos(x: f64) -> f64 {
    libm_cos(x)
}

/// libm's `sin`, as a call LLVM cannot merge with a `cos` into `sincos`
/// (also the scalar reference of [`crate::lanes_math`]).
#[inline(never)]
pub(crate) fn libm_sin(x: f64) -> f64 {
    x.sin()
}

/// libm's `cos`, as a call LLVM cannot merge with a `sin` into `sincos`.
#[inline(never)]
pub(crate) fn libm_cos(x: f64) -> f64 {
    x.cos()
}

/// `(math.sin(x), math.cos(x))`: two libm calls, never glibc's `sincos`
/// (see [`sin`]); what Gymnasium computes, and what
/// [`crate::lanes_math::sincos_lanes`] returns.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    (sin(x), cos(x))
}

#[cfg(test)]
mod sin_cos_tests {
    /// At this argument glibc 2.36's `sincos` gives a sine one ulp below
    /// `sin`'s (and Python's `math.sin`, `0x3fefd27acee550dc`); `sin_cos`
    /// must give `sin`'s bits wherever it runs.
    #[test]
    fn sin_cos_is_sin_and_cos_not_sincos() {
        let x = f64::from_bits(0x3ffad1fb54442d18);
        let (s, c) = super::sin_cos(x);
        assert_eq!(s.to_bits(), super::sin(x).to_bits());
        assert_eq!(c.to_bits(), super::cos(x).to_bits());
        if cfg!(all(
            target_os = "linux",
            target_env = "gnu",
            target_arch = "x86_64"
        )) {
            // The bits Python's math.sin/math.cos give on glibc (checked on 2.36).
            assert_eq!(s.to_bits(), 0x3fefd27acee550dc);
            assert_eq!(c.to_bits(), 0xbfbaf33152f68f8b);
        }
    }
}
