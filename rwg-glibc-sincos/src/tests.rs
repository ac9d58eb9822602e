//! The kernels and the table against this process's libm (glibc 2.36 on
//! x86-64 with AVX2+FMA gives the same bits; `rwg_env::lanes_math`'s tests
//! and self-check cover many more arguments). Skipped on a CPU without AVX2
//! and FMA, where the kernels must not run.

use super::table::SINCOSTAB;
use super::{cos_lanes, sin_lanes, sincos_lanes};

/// libm's `sin`, in a function of its own: LLVM merges a `sin` and a `cos`
/// of one argument in one function into a `sincos` call, whose bits differ.
#[inline(never)]
fn libm_sin(x: f64) -> f64 {
    x.sin()
}

/// libm's `cos` (see [`libm_sin`]).
#[inline(never)]
fn libm_cos(x: f64) -> f64 {
    x.cos()
}

/// The fallback for lanes beyond the vector range in [`lanes_beyond_the_range_go_to_the_fallback`].
fn marker(_: f64) -> f64 {
    42.0
}

fn cpu_has_avx2_fma() -> bool {
    let ok = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
    if !ok {
        eprintln!("no AVX2+FMA on this CPU: the kernels cannot run here");
    }
    ok
}

/// The three entry points on `x` against one libm `sin` and one libm `cos`
/// call per argument.
fn check(x: &[f64]) {
    let n = x.len();
    let (mut s, mut c, mut s2, mut c2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    // SAFETY: the callers checked the CPU (cpu_has_avx2_fma).
    unsafe {
        sin_lanes(x, &mut s, libm_sin);
        cos_lanes(x, &mut c, libm_cos);
        sincos_lanes(x, &mut s2, &mut c2, libm_sin, libm_cos);
    }
    for (i, &v) in x.iter().enumerate() {
        let (ws, wc) = (libm_sin(v).to_bits(), libm_cos(v).to_bits());
        let b = v.to_bits();
        assert_eq!(s[i].to_bits(), ws, "sin({v:e} = {b:#x})");
        assert_eq!(c[i].to_bits(), wc, "cos({v:e} = {b:#x})");
        assert_eq!(s2[i].to_bits(), ws, "sincos({v:e} = {b:#x}).0");
        assert_eq!(c2[i].to_bits(), wc, "sincos({v:e} = {b:#x}).1");
    }
}

/// Arguments on every path and near its limits, both signs.
fn arguments() -> Vec<f64> {
    let mut x = vec![
        0.0,
        f64::from_bits(1),
        f64::MIN_POSITIVE,
        1e-9,
        0.1,
        0.5,
        1.0,
    ];
    for limit in [
        0x3e50_0000_0000_0000u64, // sin: x
        0x3e40_0000_0000_0000,    // cos: 1
        0x3fc0_20c4_9ba5_e354,    // 0.126: Taylor / table
        0x3feb_6000_0000_0000,    // small / middle
        0x4003_68fd_0000_0000,    // middle / reduction
    ] {
        for d in -4i64..=4 {
            x.push(f64::from_bits((limit as i64 + d) as u64));
        }
    }
    // Every table point's rounding boundary k/128 + 1/256, and a sweep.
    x.extend((0..110).map(|k| (k as f64 + 0.5) / 128.0));
    x.extend((1..4000).map(|i| i as f64 * 0.0123457));
    x.extend((1..2000).map(|i| (i as f64 * 0.0173).exp()));
    let neg: Vec<f64> = x.iter().map(|v| -v).collect();
    x.extend(neg);
    x
}

#[test]
fn kernels_give_libm_bits() {
    if !cpu_has_avx2_fma() {
        return;
    }
    let x = arguments();
    check(&x);
    // Every short length and offset: the zero-padded tail.
    for len in 0..=9 {
        for start in 0..4 {
            check(&x[start..start + len]);
        }
    }
}

#[test]
fn lanes_beyond_the_range_go_to_the_fallback() {
    if !cpu_has_avx2_fma() {
        return;
    }
    let x = [1.0, 1e300, f64::NAN, f64::INFINITY, -2e8, 105_414_335.0];
    let (mut s, mut c, mut s2, mut c2) = ([0.0; 6], [0.0; 6], [0.0; 6], [0.0; 6]);
    // SAFETY: the CPU has AVX2 and FMA (checked above).
    unsafe {
        sin_lanes(&x, &mut s, marker);
        cos_lanes(&x, &mut c, marker);
        sincos_lanes(&x, &mut s2, &mut c2, marker, marker);
    }
    for out in [s, c, s2, c2] {
        assert_eq!(out[1..5], [42.0; 4], "{out:?}");
        assert_ne!(out[0], 42.0);
        assert_ne!(out[5], 42.0);
    }
    assert_eq!(s[0].to_bits(), libm_sin(1.0).to_bits());
    assert_eq!(c[5].to_bits(), libm_cos(105_414_335.0).to_bits());
}

#[test]
fn table_rows_are_sin_and_cos_of_k_over_128() {
    // Row k: sin(k/128) rounded and what rounding lost, then cos likewise.
    for k in 0..110 {
        let r = &SINCOSTAB.0[4 * k..4 * k + 4];
        let x = k as f64 / 128.0;
        assert_eq!(r[0].to_bits(), libm_sin(x).to_bits(), "row {k}: sin");
        assert_eq!(r[2].to_bits(), libm_cos(x).to_bits(), "row {k}: cos");
        for (v, err) in [(r[0], r[1]), (r[2], r[3])] {
            let ulp = f64::from_bits(v.to_bits() + 1) - v;
            assert!(err.abs() <= ulp / 2.0, "row {k}: {err:e}");
        }
    }
}
