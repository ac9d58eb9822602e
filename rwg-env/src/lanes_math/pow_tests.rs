//! The lanes' `pow(x, 2)` against libm's, one call per argument.

use super::*;
use crate::float::{hard_square, pow2_libm};

/// Checks the dispatched, the scalar and (at every level the CPU has) the
/// vector `pow2_lanes` and the port alone on `x` against one libm call per
/// argument.
fn check(x: &[f64]) {
    let n = x.len();
    let mut out = vec![0.0; n];
    type Lanes = dyn Fn(&[f64], &mut [f64]);
    let mut impls: Vec<(&str, Box<Lanes>)> = vec![
        ("dispatched", Box::new(pow2_lanes)),
        ("scalar", Box::new(scalar::pow2_lanes)),
    ];
    for v in Vector::all() {
        impls.push((v.name(), Box::new(move |x, o| v.pow2_lanes(x, o))));
        impls.push(("port", Box::new(move |x, o| v.pow2_port_lanes(x, o))));
    }
    for (name, f) in &impls {
        f(x, &mut out);
        assert_libm_bits(name, x, &out);
    }
}

/// Asserts that `out[i]` has the bits of libm's `pow(x[i], 2)` (any NaN
/// for a NaN), naming `name` and the argument otherwise.
pub(super) fn assert_libm_bits(name: &str, x: &[f64], out: &[f64]) {
    for (&v, &o) in x.iter().zip(out) {
        let want = pow2_libm(v);
        assert!(
            o.to_bits() == want.to_bits() || (want.is_nan() && o.is_nan()),
            "{name} pow({v:e} = {:#x}, 2): {:#x}, libm {:#x}",
            v.to_bits(),
            o.to_bits(),
            want.to_bits()
        );
    }
}

/// xorshift64 over [0, 1).
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn edge_arguments_give_libm_bits() {
    let x = pow2_edge_arguments();
    check(&x);
    // Every short length and offset: the scalar tail.
    for len in 0..=9 {
        for start in 0..4 {
            check(&x[start..(start + len).min(x.len())]);
        }
    }
}

#[test]
fn hard_squares_give_libm_bits() {
    // Only squares the fast path leaves, over the envs' ranges and the
    // port's: where the port alone decides, and where pow and x*x differ.
    let mut r = Rng(0x9e37_79b9_7f4a_7c15);
    let mut differs = 0;
    for range in [1.0, 8.0, 30.0, 0.0] {
        let mut x = Vec::with_capacity(1 << 16);
        while x.len() < 1 << 16 {
            let m = if range == 0.0 {
                (r.unit() * 92.0 - 60.0).exp2()
            } else {
                r.unit() * range
            };
            let v = if r.unit() < 0.5 { -m } else { m };
            if hard_square(v) {
                x.push(v);
            }
        }
        check(&x);
        differs += x.iter().filter(|&&v| pow2_libm(v) != v * v).count();
    }
    assert!(
        differs > 0,
        "no argument where pow(x, 2) != x*x: the test is blind"
    );
}

#[test]
fn ranges_give_libm_bits() {
    let mut r = Rng(0x2545_f491_4f6c_dd1d);
    for range in [1.0, 8.0, 30.0, 1e6] {
        let x: Vec<f64> = (0..1 << 17)
            .map(|_| range * (2.0 * r.unit() - 1.0))
            .collect();
        check(&x);
    }
}

#[test]
fn special_values() {
    let x = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f64::from_bits(1),
        f64::MIN_POSITIVE,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e300,
        -1e-300,
        2f64.powi(-61),
        2f64.powi(33),
    ];
    check(&x);
}
