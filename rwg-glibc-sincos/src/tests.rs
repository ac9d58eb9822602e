//! The kernels and the table against this process's libm (glibc 2.36 on
//! x86-64 with AVX2+FMA gives the same bits; `rwg_env::lanes_math`'s tests
//! and self-check cover many more arguments), at every width: four lanes
//! (AVX2+FMA), eight (AVX-512) and eight in plain Rust (`soft`: the
//! algorithm at eight lanes on any CPU). A width whose instructions this
//! CPU lacks is left out, with a note on stderr.

mod soft;

use super::table::SINCOSTAB;

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

/// A libm function.
type Libm = fn(f64) -> f64;
/// `sin_lanes` or `cos_lanes` of one width.
type One = unsafe fn(&[f64], &mut [f64], Libm);
/// `sincos_lanes` of one width.
type Both = unsafe fn(&[f64], &mut [f64], &mut [f64], Libm, Libm);

/// One width's three entry points.
struct Width {
    name: &'static str,
    sin: One,
    cos: One,
    sincos: Both,
}

impl Width {
    /// sin, cos and sincos of `x` with fallback `fs` / `fc`.
    fn eval(&self, x: &[f64], fs: fn(f64) -> f64, fc: fn(f64) -> f64) -> [Vec<f64>; 4] {
        let n = x.len();
        let mut r = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let [s, c, s2, c2] = &mut r;
        // SAFETY: `widths` lists only widths this CPU runs.
        unsafe {
            (self.sin)(x, s, fs);
            (self.cos)(x, c, fc);
            (self.sincos)(x, s2, c2, fs, fc);
        }
        r
    }
}

fn cpu_has_avx2_fma() -> bool {
    is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
}

fn cpu_has_avx512() -> bool {
    cpu_has_avx2_fma()
        && is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512dq")
        && is_x86_feature_detected!("avx512vl")
}

/// The widths this CPU runs (the plain-Rust eight lanes always).
fn widths() -> Vec<Width> {
    let mut w = vec![Width {
        name: "soft8",
        sin: soft::sin_lanes,
        cos: soft::cos_lanes,
        sincos: soft::sincos_lanes,
    }];
    if cpu_has_avx2_fma() {
        w.push(Width {
            name: "avx2",
            sin: super::sin_lanes,
            cos: super::cos_lanes,
            sincos: super::sincos_lanes,
        });
    } else {
        eprintln!("no AVX2+FMA on this CPU: the four-lane code cannot run here");
    }
    if cpu_has_avx512() {
        w.push(Width {
            name: "avx512",
            sin: super::avx512::sin_lanes,
            cos: super::avx512::cos_lanes,
            sincos: super::avx512::sincos_lanes,
        });
    } else {
        eprintln!("no AVX-512F/DQ/VL on this CPU: the eight-lane AVX-512 code cannot run here");
    }
    w
}

/// Every width's three entry points on `x` against one libm `sin` and one
/// libm `cos` call per argument, and against each other.
fn check(widths: &[Width], x: &[f64]) {
    let want: Vec<(u64, u64)> = x
        .iter()
        .map(|&v| (libm_sin(v).to_bits(), libm_cos(v).to_bits()))
        .collect();
    for w in widths {
        let [s, c, s2, c2] = w.eval(x, libm_sin, libm_cos);
        let name = w.name;
        for (i, &v) in x.iter().enumerate() {
            let (ws, wc) = want[i];
            let b = v.to_bits();
            let n = x.len();
            assert_eq!(
                s[i].to_bits(),
                ws,
                "{name} sin({v:e} = {b:#x}), lane {i} of {n}"
            );
            assert_eq!(
                c[i].to_bits(),
                wc,
                "{name} cos({v:e} = {b:#x}), lane {i} of {n}"
            );
            assert_eq!(s2[i].to_bits(), ws, "{name} sincos({v:e} = {b:#x}).0");
            assert_eq!(c2[i].to_bits(), wc, "{name} sincos({v:e} = {b:#x}).1");
        }
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

/// `n` pseudo-random arguments (xorshift64 from `seed`), both signs: a
/// quarter each uniform over |x| < 0.9, < 2.5 and < 200, and log-uniform
/// over 2^-30..2^27 (every path, the reduction's whole range).
fn random_arguments(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let m = match i % 4 {
                0 => 0.9 * u,
                1 => 2.5 * u,
                2 => 200.0 * u,
                _ => (u * 57.0 - 30.0).exp2(),
            };
            if s & 1 == 1 {
                -m
            } else {
                m
            }
        })
        .collect()
}

#[test]
fn kernels_give_libm_bits() {
    let w = widths();
    check(&w, &arguments());
    check(&w, &random_arguments(0x2545_f491_4f6c_dd1d, 1 << 17));
}

#[test]
fn every_tail_length_gives_libm_bits() {
    // Every length 0..=40 at every offset of an eight-lane group: full
    // groups, then a tail of 0 to 7 lanes (of 0 to 3 at four lanes); lanes
    // beyond the vector range (NaN, inf, huge) among them, so the fallback
    // runs in tails too.
    let w = widths();
    let mut x = random_arguments(0x9e37_79b9_7f4a_7c15, 64);
    for (i, v) in [f64::NAN, 1e300, f64::NEG_INFINITY, -2e8, 0.0, 1e-300]
        .into_iter()
        .enumerate()
    {
        x[7 * i + 3] = v;
    }
    for len in 0..=40 {
        for start in 0..8 {
            check(&w, &x[start..start + len]);
        }
    }
}

#[test]
fn every_width_gives_the_four_lane_bits() {
    let w = widths();
    let x: Vec<f64> = arguments()
        .into_iter()
        .chain(random_arguments(7, 1 << 15))
        .collect();
    let results: Vec<[Vec<f64>; 4]> = w.iter().map(|w| w.eval(&x, libm_sin, libm_cos)).collect();
    let bits = |r: &[Vec<f64>; 4]| r.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    let Some(four) = w.iter().position(|w| w.name == "avx2") else {
        return; // noted on stderr by `widths`
    };
    for (wi, r) in w.iter().zip(&results) {
        assert!(
            bits(r) == bits(&results[four]),
            "{} differs from avx2",
            wi.name
        );
    }
}

#[test]
fn lanes_beyond_the_range_go_to_the_fallback() {
    let mut x = [0.5; 19];
    x[..6].copy_from_slice(&[1.0, 1e300, f64::NAN, f64::INFINITY, -2e8, 105_414_335.0]);
    x[17] = f64::NEG_INFINITY; // in an eight-lane tail
    for w in widths() {
        for (i, out) in w.eval(&x, marker, marker).iter().enumerate() {
            let name = w.name;
            assert_eq!(out[1..5], [42.0; 4], "{name} {i}: {out:?}");
            assert_eq!(out[17], 42.0, "{name} {i}: {out:?}");
            for j in (0..19).filter(|j| !(1..5).contains(j) && *j != 17) {
                assert_ne!(out[j], 42.0, "{name} {i}: {out:?}");
            }
        }
    }
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
