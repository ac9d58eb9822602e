//! The lanes' bits against libm's `sin` and `cos`, one call per argument,
//! at every level this CPU has; each level's decision and its printed form.

use super::*;

/// sin, cos and sincos (sin, cos) of the first slice into the others.
type Impl = dyn Fn(&[f64], &mut [f64], &mut [f64], &mut [f64], &mut [f64]);

/// Checks the dispatched, the scalar and the vector functions of every
/// level the CPU has on `x` against one libm call per argument.
fn check(x: &[f64]) {
    let n = x.len();
    let (mut s, mut c, mut s2, mut c2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut impls: Vec<(&str, Box<Impl>)> = vec![
        (
            "dispatched",
            Box::new(|x, s, c, s2, c2| {
                sin_lanes(x, s);
                cos_lanes(x, c);
                sincos_lanes(x, s2, c2);
            }),
        ),
        (
            "scalar",
            Box::new(|x, s, c, s2, c2| {
                scalar::sin_lanes(x, s);
                scalar::cos_lanes(x, c);
                scalar::sincos_lanes(x, s2, c2);
            }),
        ),
    ];
    for v in Vector::all() {
        impls.push((
            v.name(),
            Box::new(move |x, s, c, s2, c2| {
                v.sin_lanes(x, s);
                v.cos_lanes(x, c);
                v.sincos_lanes(x, s2, c2);
            }),
        ));
    }
    for (name, f) in &impls {
        f(x, &mut s, &mut c, &mut s2, &mut c2);
        for i in 0..n {
            let (ws, wc) = (libm_sin(x[i]).to_bits(), libm_cos(x[i]).to_bits());
            let v = x[i];
            assert_eq!(s[i].to_bits(), ws, "{name} sin({v:e} = {:#x})", v.to_bits());
            assert_eq!(c[i].to_bits(), wc, "{name} cos({v:e} = {:#x})", v.to_bits());
            assert_eq!(s2[i].to_bits(), ws, "{name} sincos({v:e}).0");
            assert_eq!(c2[i].to_bits(), wc, "{name} sincos({v:e}).1");
        }
    }
}

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self, r: f64) -> f64 {
        r * (2.0 * self.unit() - 1.0)
    }
}

#[test]
fn edge_arguments_give_libm_bits() {
    let x = edge_arguments();
    check(&x);
    // Every short length and offset: the tails of four and eight lanes.
    for len in 0..=17 {
        for start in 0..8 {
            check(&x[start..(start + len).min(x.len())]);
        }
    }
}

/// What `decide` should return at `level`, worked out from the CPU and the
/// environment; `mismatch` is the self-check.
fn expected(
    level: Simd,
    mismatch: &dyn Fn(Vector) -> Option<(&'static str, f64)>,
) -> Implementation {
    if level == Simd::Scalar {
        return Implementation::Scalar(if Simd::cpu() == Simd::Scalar {
            ScalarReason::NoCpuSupport(Simd::Avx2)
        } else {
            ScalarReason::Forced
        });
    }
    if !level.available() {
        return Implementation::Scalar(ScalarReason::NoCpuSupport(level));
    }
    let v = Vector::all()
        .into_iter()
        .find(|v| v.level() == level)
        .unwrap();
    match mismatch(v) {
        None => Implementation::Vector(level),
        Some((f, x)) => Implementation::Scalar(ScalarReason::SelfCheckFailed(level, f, x)),
    }
}

#[test]
fn dispatch_follows_level_cpu_and_self_check() {
    // Every level has its own decisions, one per function, each with its
    // own self-check. NaN != NaN: compare the printed form.
    for level in Simd::ALL {
        let sin_cos = implementation_at(level);
        let want = if SIN_COS_BUILT_IN {
            expected(level, &|v| {
                v.first_mismatch(&edge_arguments()).map(|x| ("sin/cos", x))
            })
        } else {
            Implementation::Scalar(ScalarReason::NotBuiltIn)
        };
        assert_eq!(format!("{sin_cos}"), format!("{want}"), "{level}");
        let pow = pow_implementation_at(level);
        let want = expected(level, &|v| {
            v.first_pow2_mismatch(&pow2_edge_arguments())
                .map(|x| ("pow", x))
        });
        assert_eq!(format!("{pow}"), format!("{want}"), "{level}");
        eprintln!("lanes_math at {level}: sin/cos {sin_cos}; pow {pow}");
    }
    // The process's choice is that of RWG_SIMD's level (else the CPU's).
    let level = crate::simd::level();
    assert_eq!(
        format!("{}", implementation()),
        format!("{}", implementation_at(level))
    );
    assert_eq!(
        format!("{}", pow_implementation()),
        format!("{}", pow_implementation_at(level))
    );
}

#[test]
fn levels_are_named() {
    let show = |i: Implementation| i.to_string();
    assert_eq!(
        show(Implementation::Vector(Simd::Avx512)),
        "vector (AVX-512, 8 lanes, glibc 2.36's bits, self-check passed)"
    );
    assert_eq!(
        show(Implementation::Vector(Simd::Avx2)),
        "vector (AVX2+FMA, 4 lanes, glibc 2.36's bits, self-check passed)"
    );
    assert_eq!(
        show(Implementation::Scalar(ScalarReason::Forced)),
        "scalar (RWG_SIMD=scalar)"
    );
    let no = |l| show(Implementation::Scalar(ScalarReason::NoCpuSupport(l)));
    assert_eq!(
        no(Simd::Avx512),
        "scalar (no AVX-512F, DQ and VL on this CPU)"
    );
    assert_eq!(no(Simd::Avx2), "scalar (no x86-64 CPU with AVX2 and FMA)");
    let failed = ScalarReason::SelfCheckFailed(Simd::Avx512, "sin/cos", 1.5);
    assert_eq!(
        show(Implementation::Scalar(failed)),
        "scalar (the vector sin/cos (AVX-512, 8 lanes) differs from this libm at x = 1.5e0 \
         = 0x3ff8000000000000)"
    );
    for v in Vector::all() {
        assert_eq!(v.lanes(), if v.level() == Simd::Avx512 { 8 } else { 4 });
        assert!(v.name().contains(&format!("{} lanes", v.lanes())));
    }
}

/// A failing self-check turns off only the functions it checked, at its
/// level only: each decision runs its own check.
#[test]
fn a_failed_self_check_names_its_function_and_level() {
    for v in Vector::all() {
        let level = v.level();
        assert_eq!(
            decide(level, |_| Some(("pow", 1.5))),
            Implementation::Scalar(ScalarReason::SelfCheckFailed(level, "pow", 1.5))
        );
        assert_eq!(decide(level, |_| None), Implementation::Vector(level));
        let text = format!("{}", decide(level, |_| Some(("pow", 1.5))));
        assert!(
            text.contains("the vector pow") && text.contains(v.name()),
            "{text}"
        );
    }
    // Levels the CPU lacks are never checked.
    for level in Simd::ALL.into_iter().filter(|l| !l.available()) {
        assert_eq!(
            decide(level, |_| panic!("no self-check at {level}")),
            Implementation::Scalar(ScalarReason::NoCpuSupport(level))
        );
    }
    assert!(Vector::at(Simd::Scalar).is_none());
}

#[test]
fn ranges_give_libm_bits() {
    // ~1.2e6 arguments over the envs' ranges and log-uniform over all paths.
    let mut r = Rng(0x2545_f491_4f6c_dd1d);
    let mut x = Vec::with_capacity(1 << 17);
    for range in [0.3, 0.9, 2.5, 3.6, 20.0, 200.0] {
        x.clear();
        x.extend((0..1 << 17).map(|_| r.sym(range)));
        check(&x);
    }
    for _ in 0..4 {
        x.clear();
        x.extend((0..1 << 17).map(|_| {
            let m = (r.unit() * (2.2e8f64 / 1e-12).ln()).exp() * 1e-12;
            if r.unit() < 0.5 {
                -m
            } else {
                m
            }
        }));
        check(&x);
    }
}

#[test]
fn special_values() {
    let x = [
        0.0,
        -0.0,
        f64::from_bits(1),
        -f64::from_bits(1),
        f64::MIN_POSITIVE,
        f64::NAN,
        -f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e300,
        -1e300,
        105414350.0,
        105414349.0,
    ];
    check(&x);
    let mut s = [0.0; 13];
    sin_lanes(&x, &mut s);
    assert_eq!(s[1].to_bits(), (-0.0f64).to_bits());
    assert!(s[5].is_nan() && s[7].is_nan());
}

#[test]
#[should_panic(expected = "sin_lanes: arguments and results")]
fn lengths_must_match() {
    sin_lanes(&[1.0, 2.0], &mut [0.0]);
}

#[test]
fn sincos_lanes_is_not_glibc_sincos() {
    // glibc 2.36's sincos gives a sine one ulp below sin's here (x86-64 FMA
    // variant); the lanes must give sin's bits.
    let x = f64::from_bits(0x3ffa_d1fb_5444_2d18);
    let (mut s, mut c) = ([0.0], [0.0]);
    sincos_lanes(&[x], &mut s, &mut c);
    assert_eq!(s[0].to_bits(), libm_sin(x).to_bits());
    assert_eq!(c[0].to_bits(), libm_cos(x).to_bits());
}
