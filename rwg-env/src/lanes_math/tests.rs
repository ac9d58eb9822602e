//! The lanes' bits against libm's `sin` and `cos`, one call per argument.

use super::*;

/// sin, cos and sincos (sin, cos) of the first slice into the others.
type Impl = dyn Fn(&[f64], &mut [f64], &mut [f64], &mut [f64], &mut [f64]);

/// Checks the dispatched, the scalar and (where the CPU has it) the vector
/// functions on `x` against one libm call per argument.
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
    if let Some(v) = Vector::detect() {
        impls.push((
            "vector",
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
    // Every short length and offset: the zero-padded tail.
    for len in 0..=9 {
        for start in 0..4 {
            check(&x[start..(start + len).min(x.len())]);
        }
    }
}

#[test]
fn dispatch_follows_cpu_and_self_check() {
    let expected = |mismatch: &dyn Fn(Vector) -> Option<(&'static str, f64)>| {
        if std::env::var_os("RWG_SCALAR_LIBM").is_some_and(|v| v == "1") {
            Implementation::Scalar(ScalarReason::Forced)
        } else {
            match Vector::detect() {
                None => Implementation::Scalar(ScalarReason::NoCpuSupport),
                Some(v) => match mismatch(v) {
                    None => Implementation::Vector,
                    Some((f, x)) => Implementation::Scalar(ScalarReason::SelfCheckFailed(f, x)),
                },
            }
        }
    };
    // Each decision has its own self-check. NaN != NaN: compare the printed
    // form.
    let sin_cos = implementation();
    let want = if SIN_COS_BUILT_IN {
        expected(&|v| v.first_mismatch(&edge_arguments()).map(|x| ("sin/cos", x)))
    } else {
        Implementation::Scalar(ScalarReason::NotBuiltIn)
    };
    assert_eq!(format!("{sin_cos}"), format!("{want}"));
    let pow = pow_implementation();
    let want = expected(&|v| {
        v.first_pow2_mismatch(&pow2_edge_arguments())
            .map(|x| ("pow", x))
    });
    assert_eq!(format!("{pow}"), format!("{want}"));
    eprintln!("lanes_math: sin/cos {sin_cos}; pow {pow}");
}

/// A failing self-check turns off only the functions it checked: each
/// decision runs its own check.
#[test]
fn a_failed_self_check_names_its_function() {
    if std::env::var_os("RWG_SCALAR_LIBM").is_some_and(|v| v == "1") || Vector::detect().is_none() {
        return; // decided before any self-check (dispatch_follows_cpu_and_self_check)
    }
    assert_eq!(
        decide(|_| Some(("pow", 1.5))),
        Implementation::Scalar(ScalarReason::SelfCheckFailed("pow", 1.5))
    );
    assert_eq!(decide(|_| None), Implementation::Vector);
    assert!(format!("{}", decide(|_| Some(("pow", 1.5)))).contains("the vector pow differs"));
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
