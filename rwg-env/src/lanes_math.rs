//! glibc's `sin` and `cos` over many arguments at once, for environments
//! stepped in lockstep over lanes (structure of arrays).
//!
//! Contract: every output is bit for bit what this process's libm (`f64::sin`
//! / `f64::cos`, glibc on Linux) returns for the same argument, whatever
//! implementation runs underneath. Gymnasium computes these with Python's
//! `math.sin` / `math.cos` (glibc), so the envs' trajectories depend on
//! exactly these bits. Slices must have equal lengths (panics otherwise).
//!
//! Today each element is one libm call; a vector implementation may replace
//! the loops only where it is proven to return the same bits.

/// `out[i] = x[i].sin()` for every `i`.
pub fn sin_lanes(x: &[f64], out: &mut [f64]) {
    assert_eq!(x.len(), out.len(), "sin_lanes: arguments and results");
    for (o, &v) in out.iter_mut().zip(x) {
        *o = v.sin();
    }
}

/// `out[i] = x[i].cos()` for every `i`.
pub fn cos_lanes(x: &[f64], out: &mut [f64]) {
    assert_eq!(x.len(), out.len(), "cos_lanes: arguments and results");
    for (o, &v) in out.iter_mut().zip(x) {
        *o = v.cos();
    }
}

/// `sin[i] = x[i].sin()` and `cos[i] = x[i].cos()` for every `i` (glibc's
/// `sincos` returns the bits of `sin` and `cos`).
pub fn sincos_lanes(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    assert_eq!(x.len(), sin.len(), "sincos_lanes: arguments and sines");
    assert_eq!(x.len(), cos.len(), "sincos_lanes: arguments and cosines");
    for ((s, c), &v) in sin.iter_mut().zip(cos.iter_mut()).zip(x) {
        let (a, b) = v.sin_cos();
        *s = a;
        *c = b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_give_libm_bits() {
        let x: Vec<f64> = (0..1000)
            .map(|i| (i as f64 - 500.0) * 0.0137 + 1e-9 * i as f64)
            .chain([0.0, -0.0, 1e-300, 1e300, f64::NAN, f64::INFINITY])
            .collect();
        let (mut s, mut c, mut s2, mut c2) = (
            vec![0.0; x.len()],
            vec![0.0; x.len()],
            vec![0.0; x.len()],
            vec![0.0; x.len()],
        );
        sin_lanes(&x, &mut s);
        cos_lanes(&x, &mut c);
        sincos_lanes(&x, &mut s2, &mut c2);
        for (i, &v) in x.iter().enumerate() {
            assert_eq!(s[i].to_bits(), v.sin().to_bits(), "sin({v:e})");
            assert_eq!(c[i].to_bits(), v.cos().to_bits(), "cos({v:e})");
            assert_eq!(s2[i].to_bits(), v.sin().to_bits(), "sincos({v:e}).0");
            assert_eq!(c2[i].to_bits(), v.cos().to_bits(), "sincos({v:e}).1");
        }
    }
}
