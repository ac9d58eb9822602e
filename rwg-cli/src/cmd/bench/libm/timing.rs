//! `rwg bench libm`'s timings: the cost per element of libm and of a
//! vector level on 16-lane slices, in interleaved rounds.

use super::{pow_args, Rng, POW_RANGES, RANGES};
use crate::cmd::bench::{spread, Clock};
use rwg_analysis::table::{Align, TextColumns};
use rwg_env::lanes_math::{scalar, Vector};
use std::hint::black_box;
use std::time::Instant;

/// sin, cos or sincos of a slice into one or two output slices.
type Lanes = dyn Fn(&[f64], &mut [f64], &mut [f64]);

/// CPU (else wall) nanoseconds per element of `f` over `x` in slices of 16,
/// repeated for at least ~20 ms.
fn per_element(x: &[f64], out: &mut [f64], out2: &mut [f64], f: &Lanes) -> f64 {
    let mut reps = 0u64;
    let clock = Clock::start();
    let wall = Instant::now();
    while reps == 0 || wall.elapsed().as_secs_f64() < 0.02 {
        for ((xs, o), o2) in x
            .chunks(16)
            .zip(out.chunks_mut(16))
            .zip(out2.chunks_mut(16))
        {
            f(black_box(xs), o, o2);
        }
        black_box(&mut *out);
        black_box(&mut *out2);
        reps += 1;
    }
    let (w, cpu) = clock.stop();
    cpu.unwrap_or(w) * 1e9 / (reps as f64 * x.len() as f64)
}

/// `rounds` interleaved rounds of scalar `sf` and vector `vf` over `x`
/// (alternating which goes first): the scalar and vector ns per element and
/// the per-round speed-up, each as "median [min-max]".
fn interleaved(
    x: &[f64],
    out: &mut [f64],
    out2: &mut [f64],
    rounds: usize,
    sf: &Lanes,
    vf: &Lanes,
) -> [String; 3] {
    let (mut s, mut v, mut ratio) = (vec![], vec![], vec![]);
    for round in 0..rounds {
        let (a, b) = if round % 2 == 0 {
            let a = per_element(x, out, out2, sf);
            (a, per_element(x, out, out2, vf))
        } else {
            let b = per_element(x, out, out2, vf);
            (per_element(x, out, out2, sf), b)
        };
        s.push(a);
        v.push(b);
        ratio.push(a / b);
    }
    let show = |t: (f64, f64, f64)| format!("{:.2} [{:.2}-{:.2}]", t.0, t.1, t.2);
    [show(spread(&s)), show(spread(&v)), show(spread(&ratio))]
}

/// Prints libm vs vector level `v`'s `pow(x, 2)` ns per element for each
/// of [`POW_RANGES`], `rounds` interleaved rounds.
pub(super) fn time_pow(v: Vector, rounds: usize, seed: u64) {
    const N: usize = 4096;
    crate::outln!(
        "\npow(x, 2), {}: CPU ns per element on 16-lane slices ({N} arguments per range), \
         libm per element vs pow2_lanes, {rounds} interleaved rounds: median [min-max]:",
        v.name()
    );
    let cols = TextColumns::new(
        &[
            (8, Align::Left),
            (20, Align::Right),
            (20, Align::Right),
            (20, Align::Right),
        ],
        "  ",
    );
    crate::outln!(
        "{}",
        cols.line(&["range", "libm (scalar)", v.level().name(), "speed-up"])
    );
    let sf: Box<Lanes> = Box::new(|x, o, _| scalar::pow2_lanes(x, o));
    let vf: Box<Lanes> = Box::new(move |x, o, _| v.pow2_lanes(x, o));
    let (mut out, mut out2) = (vec![0.0; N], vec![0.0; N]);
    for (ri, r) in POW_RANGES.iter().enumerate() {
        let mut rng = Rng::new(seed ^ 0x9abc ^ (ri as u64) << 48);
        let x = pow_args(&mut rng, r, N);
        let [s, vv, ratio] = interleaved(&x, &mut out, &mut out2, rounds, &*sf, &*vf);
        crate::outln!("{}", cols.line(&[r.name.to_string(), s, vv, ratio]));
    }
}

/// Prints scalar vs vector level `v`'s ns per element for each range and
/// function, `rounds` interleaved rounds (the order alternating).
pub(super) fn time(v: Vector, rounds: usize, seed: u64) {
    const N: usize = 4096;
    crate::outln!(
        "\nsin/cos, {}: CPU ns per element on 16-lane slices ({N} arguments per range), \
         {rounds} interleaved rounds: median [min-max]; speed-up = per-round scalar / vector:",
        v.name()
    );
    let cols = TextColumns::new(
        &[
            (8, Align::Left),
            (6, Align::Left),
            (20, Align::Right),
            (20, Align::Right),
            (20, Align::Right),
        ],
        "  ",
    );
    crate::outln!(
        "{}",
        cols.line(&["range", "fn", "libm (scalar)", v.level().name(), "speed-up"])
    );
    let fns: [(&str, Box<Lanes>, Box<Lanes>); 3] = [
        (
            "sin",
            Box::new(|x, o, _| scalar::sin_lanes(x, o)),
            Box::new(move |x, o, _| v.sin_lanes(x, o)),
        ),
        (
            "cos",
            Box::new(|x, o, _| scalar::cos_lanes(x, o)),
            Box::new(move |x, o, _| v.cos_lanes(x, o)),
        ),
        (
            "sincos",
            Box::new(scalar::sincos_lanes),
            Box::new(move |x, o, o2| v.sincos_lanes(x, o, o2)),
        ),
    ];
    let (mut out, mut out2) = (vec![0.0; N], vec![0.0; N]);
    for (ri, r) in RANGES.iter().enumerate() {
        let mut rng = Rng::new(seed ^ 0xabcd ^ (ri as u64) << 48);
        let x: Vec<f64> = (0..N).map(|_| rng.arg(r.draw)).collect();
        for (name, sf, vf) in &fns {
            let [s, vv, ratio] = interleaved(&x, &mut out, &mut out2, rounds, &**sf, &**vf);
            crate::outln!(
                "{}",
                cols.line(&[r.name.to_string(), name.to_string(), s, vv, ratio])
            );
        }
    }
}
