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
/// Fast path: when the exact square `x*x + e` lies at most 0.4 ulp from the
/// rounded product (|e| <= 0.4 ulp, e computed exactly with a fused
/// multiply-add), every result within 0.54 ulp of the exact value is `x*x`
/// itself, so `pow` must return it. Only the remaining inputs call `pow`.
#[inline]
pub fn pow2(x: f64) -> f64 {
    let p = x * x;
    if p.is_normal() && p < 1e300 {
        let e = x.mul_add(x, -p);
        // ulp of p: 2^(exponent - 52)
        let ulp = f64::from_bits((p.to_bits() & 0x7ff0_0000_0000_0000) - (52u64 << 52));
        if e.abs() <= 0.4 * ulp {
            return p;
        }
    }
    pow2_libm(x)
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
