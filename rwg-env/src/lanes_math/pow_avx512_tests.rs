//! The eight-lane `pow(x, 2)` (`pow_avx512`) against libm's, one call per
//! argument, and against the four-lane port (`pow_fma`). Each test runs
//! only on a CPU with AVX-512F, DQ and VL, and says that it skipped
//! elsewhere.

use super::pow_edges::Unit;
use super::pow_tests::assert_libm_bits;
use super::{pow2_edge_arguments, pow_avx512, pow_fma};
use crate::float::{hard_square, pow2, pow2_libm};
use crate::simd::Simd;

/// A kernel's signature: `(x, out, fallback)`.
type Kernel = unsafe fn(&[f64], &mut [f64], fn(f64) -> f64);

/// An entry point's name, its eight-lane and four-lane kernels, and the
/// fallback `Vector` gives it.
type Entry = (&'static str, Kernel, Kernel, fn(f64) -> f64);

/// Both entry points.
const KERNELS: [Entry; 2] = [
    (
        "pow2_lanes",
        pow_avx512::pow2_lanes,
        pow_fma::pow2_lanes,
        pow2,
    ),
    (
        "pow2_port_lanes",
        pow_avx512::pow2_port_lanes,
        pow_fma::pow2_port_lanes,
        pow2_libm,
    ),
];

/// What an output holds before a kernel writes it: no square is negative.
const UNWRITTEN: f64 = -7.0;

/// Whether this CPU runs AVX-512; if not, says that `test` skipped.
fn avx512(test: &str) -> bool {
    let have = Simd::Avx512.available();
    if !have {
        eprintln!("SKIPPED {test}: this CPU has no AVX-512F/DQ/VL");
    }
    have
}

/// Runs every kernel on `x` into a buffer three longer than `x`, and checks
/// each output against libm's bits and the four-lane kernel's, and that
/// nothing past the slice was written.
fn check(x: &[f64]) {
    let n = x.len();
    for (name, eight, four, fallback) in KERNELS {
        let mut out = vec![UNWRITTEN; n + 3];
        let mut out4 = vec![UNWRITTEN; n];
        // SAFETY: the tests call `check` only where the CPU has AVX-512F,
        // DQ and VL (with AVX2 and FMA).
        unsafe {
            eight(x, &mut out[..n], fallback);
            four(x, &mut out4, fallback);
        }
        assert_libm_bits(name, x, &out[..n]);
        for i in 0..n {
            assert_eq!(
                out[i].to_bits(),
                out4[i].to_bits(),
                "{name} pow({:e}, 2): eight lanes {:#x}, four lanes {:#x}",
                x[i],
                out[i].to_bits(),
                out4[i].to_bits()
            );
        }
        assert!(
            out[n..].iter().all(|o| o.to_bits() == UNWRITTEN.to_bits()),
            "{name} wrote past a slice of {n}"
        );
    }
}

/// Log-uniform over the port's range, 2^-60 <= |x| <= 2^32, either sign.
fn in_port_range(r: &mut Unit) -> f64 {
    let m = r.log_uniform();
    if r.next() < 0.5 {
        -m
    } else {
        m
    }
}

#[test]
fn eight_lanes_give_libm_bits_on_the_edge_arguments() {
    if !avx512("eight_lanes_give_libm_bits_on_the_edge_arguments") {
        return;
    }
    check(&pow2_edge_arguments());
}

#[test]
fn eight_lanes_give_libm_bits_over_the_port_range() {
    if !avx512("eight_lanes_give_libm_bits_over_the_port_range") {
        return;
    }
    let mut r = Unit(0x2545_f491_4f6c_dd1d);
    let x: Vec<f64> = (0..1 << 17).map(|_| in_port_range(&mut r)).collect();
    check(&x);
    // Only the squares the fast path leaves: every lane through the port.
    let mut hard = Vec::with_capacity(1 << 16);
    while hard.len() < 1 << 16 {
        let v = in_port_range(&mut r);
        if hard_square(v) {
            hard.push(v);
        }
    }
    check(&hard);
    assert!(
        hard.iter().any(|&v| pow2_libm(v) != v * v),
        "no argument where pow(x, 2) != x*x: the test is blind"
    );
}

#[test]
fn eight_lanes_give_libm_bits_at_every_length() {
    if !avx512("eight_lanes_give_libm_bits_at_every_length") {
        return;
    }
    // Hard squares, easy ones and the fallback's arguments mixed, so that
    // the masked tail meets every path.
    let mut r = Unit(0x9e37_79b9_7f4a_7c15);
    let edges = pow2_edge_arguments();
    let x: Vec<f64> = (0..256)
        .map(|i| match i % 3 {
            0 => edges[(r.next() * edges.len() as f64) as usize],
            _ => loop {
                let v = in_port_range(&mut r);
                if i % 3 == 1 || hard_square(v) {
                    break v;
                }
            },
        })
        .collect();
    for len in 0..=40 {
        for start in 0..9 {
            check(&x[start..start + len]);
        }
    }
}
