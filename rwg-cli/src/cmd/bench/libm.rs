//! `rwg bench libm`: the vector `sin`/`cos` and `pow(x, 2)` of
//! `rwg_env::lanes_math` at every vector level this CPU has (four AVX2+FMA
//! lanes, eight AVX-512 lanes) against this machine's libm, bit for bit over
//! many arguments (`--check N`: one libm call per argument, compared with
//! every level), and the cost per element of libm and of each level on
//! 16-lane slices, side by side. The vector `sin`/`cos` exists only in a
//! build with the `glibc-sincos` feature (the default); without it only
//! `pow` is checked and timed.

use anyhow::{bail, Result};
use rwg_analysis::table::{Align, TextColumns};
use rwg_env::lanes_math::{self, scalar, Vector};
use std::time::Instant;

mod timing;

/// Arguments of `rwg bench libm`.
#[derive(clap::Args)]
pub struct LibmArgs {
    /// Pseudo-random arguments to check (split evenly over the ranges),
    /// besides the fixed edge set; 0 checks the edge set only.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    check: u64,
    /// Pseudo-random arguments of pow(x, 2) to check (default: --check's N).
    #[arg(long, value_name = "N")]
    pow_check: Option<u64>,
    /// Seed of the pseudo-random arguments.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Interleaved timing rounds (0: no timing).
    #[arg(long, default_value_t = 7)]
    rounds: usize,
    /// Mismatches printed at most.
    #[arg(long, default_value_t = 20)]
    show: usize,
}

/// A range of arguments: name and how to draw one from a uniform `u` in
/// [0, 1) and a fair sign bit.
struct Range {
    name: &'static str,
    what: &'static str,
    draw: fn(f64) -> f64,
}

/// The envs' ranges and a log-uniform sweep over every vector path.
const RANGES: [Range; 5] = [
    Range {
        name: "cartpole",
        what: "|x| < 0.3 (CartPole's angle)",
        draw: |u| 0.3 * u,
    },
    Range {
        name: "mcc",
        what: "|x| <= 3.6 (MountainCarContinuous' cos(3 pos))",
        draw: |u| 3.6 * u,
    },
    Range {
        name: "acrobot",
        what: "|x| <= 20 (Acrobot's angles and sums)",
        draw: |u| 20.0 * u,
    },
    Range {
        name: "pendulum",
        what: "|x| <= 200 (Pendulum's theta)",
        draw: |u| 200.0 * u,
    },
    Range {
        name: "log-all",
        what: "log-uniform 2^-30 <= |x| < 105414350 (every vector path)",
        draw: |u| (u * (105_414_350f64 / 2f64.powi(-30)).ln()).exp() * 2f64.powi(-30),
    },
];

/// The ranges of `pow(x, 2)`'s arguments.
const POW_RANGES: [Range; 3] = [
    Range {
        name: "envs",
        what: "|x| <= 30 (Acrobot's velocities and d2, Pendulum's and MCC's squares)",
        draw: |u| 30.0 * u,
    },
    Range {
        name: "hard",
        what: "log-uniform 2^-60..2^32, only squares > 0.48 ulp from x*x (all ported)",
        draw: log_port_range,
    },
    Range {
        name: "log-all",
        what: "log-uniform 2^-60 <= |x| <= 2^32 (the port's whole range)",
        draw: log_port_range,
    },
];

/// Log-uniform over the port's range, 2^-60 to 2^32.
fn log_port_range(u: f64) -> f64 {
    (u * 92.0 - 60.0).exp2()
}

/// `n` arguments of pow range `r` (for "hard", only the squares the fast
/// path leaves).
fn pow_args(rng: &mut Rng, r: &Range, n: usize) -> Vec<f64> {
    let only_hard = r.name == "hard";
    let mut x = Vec::with_capacity(n);
    while x.len() < n {
        let arg = rng.arg(r.draw);
        if !only_hard || rwg_env::float::hard_square(arg) {
            x.push(arg);
        }
    }
    x
}

/// xorshift64: reproducible arguments without a dependency.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// `draw(u)` with a random sign.
    fn arg(&mut self, draw: fn(f64) -> f64) -> f64 {
        let b = self.next();
        let x = draw((b >> 11) as f64 / (1u64 << 53) as f64);
        if b & 1 == 1 {
            -x
        } else {
            x
        }
    }
}

/// Mismatch counts of one range at one level.
#[derive(Default)]
struct Tally {
    sin: u64,
    cos: u64,
    sincos: u64,
}

/// Runs `rwg bench libm`.
pub fn run(a: LibmArgs) -> Result<()> {
    crate::outln!(
        "lanes_math in use: sin/cos {}; pow {}",
        lanes_math::implementation(),
        lanes_math::pow_implementation()
    );
    let levels = Vector::all();
    if levels.is_empty() {
        crate::outln!(
            "The vector code needs an x86-64 CPU with AVX2 and FMA: nothing to check or time \
             here (every lane calls libm)."
        );
        return Ok(());
    }
    for &v in &levels {
        crate::outln!(
            "  {} ({}): sin/cos {}; pow {}",
            v.level(),
            v.name(),
            lanes_math::implementation_at(v.level()),
            lanes_math::pow_implementation_at(v.level())
        );
    }
    let sin_cos = lanes_math::SIN_COS_BUILT_IN;
    if !sin_cos {
        crate::outln!(
            "\nVector sin/cos not built in (this rwg was built without the glibc-sincos \
             feature): every sin/cos lane calls libm, nothing to check or time there."
        );
    }
    let bad = if sin_cos { check(&levels, &a)? } else { 0 } + check_pow(&levels, &a);
    if a.rounds > 0 {
        for &v in &levels {
            if sin_cos {
                timing::time(v, a.rounds, a.seed);
            }
            timing::time_pow(v, a.rounds, a.seed);
        }
    }
    if bad > 0 {
        bail!(
            "{bad} results of the vector code differ from this machine's libm: lanes_math \
             falls back to libm only if its self-check catches it; report the arguments above"
        );
    }
    Ok(())
}

/// The columns of a table with `first` (width, alignment) columns, then
/// `per_level` right-aligned columns of width `width` for each of `levels`
/// vector levels, then a free "what" column.
fn level_columns(
    first: &[(usize, Align)],
    per_level: usize,
    width: usize,
    levels: usize,
) -> TextColumns {
    let mut c = first.to_vec();
    c.extend(std::iter::repeat_n(
        (width, Align::Right),
        per_level * levels,
    ));
    c.push((0, Align::Left));
    TextColumns::new(&c, "  ")
}

/// The header cells `names` for each of `levels`, prefixed with the level's
/// name when there are several.
fn level_headers(levels: &[Vector], names: &[&str]) -> Vec<String> {
    levels
        .iter()
        .flat_map(|v| {
            names.iter().map(move |n| match levels.len() {
                1 => n.to_string(),
                _ => format!("{}:{n}", v.level()),
            })
        })
        .collect()
}

/// Compares the bits of every vector level with libm's over the edge set
/// and `a.check` random arguments; prints a table (three counts per
/// level); returns the number of differing results.
fn check(levels: &[Vector], a: &LibmArgs) -> Result<u64> {
    const CHUNK: usize = 1 << 16;
    let cols = level_columns(&[(8, Align::Left), (14, Align::Right)], 3, 13, levels.len());
    crate::outln!(
        "\nBits of sin, cos and sincos (both halves), each vector level ({}) vs one libm call \
         per argument:",
        level_names(levels)
    );
    let mut header = vec!["range".to_string(), "arguments".to_string()];
    header.extend(level_headers(levels, &["sin diff", "cos diff", "sincos"]));
    header.push("what".into());
    crate::outln!("{}", cols.line(&header));
    let started = Instant::now();
    let mut shown = 0;
    let mut total = 0;
    let mut buf = Buffers::new(CHUNK);
    let edges = lanes_math::edge_arguments();
    let mut sets: Vec<(&str, &str, u64)> =
        vec![("edges", "fixed: every path limit, table point, n pi/2", 0)];
    for (r, n) in RANGES.iter().zip(split(a.check, RANGES.len())) {
        sets.push((r.name, r.what, n));
    }
    for (si, &(name, what, n)) in sets.iter().enumerate() {
        let mut ts: Vec<Tally> = levels.iter().map(|_| Tally::default()).collect();
        let mut args = 0u64;
        let mut rng = Rng::new(a.seed ^ (si as u64) << 56);
        let mut done = 0u64;
        loop {
            let x: Vec<f64> = if si == 0 {
                if done > 0 {
                    break;
                }
                edges.clone()
            } else {
                if done >= n {
                    break;
                }
                let k = (n - done).min(CHUNK as u64) as usize;
                let draw = RANGES[si - 1].draw;
                (0..k).map(|_| rng.arg(draw)).collect()
            };
            done += x.len() as u64;
            args += x.len() as u64;
            buf.libm(&x);
            for (&v, t) in levels.iter().zip(&mut ts) {
                buf.compare(v, &x, t, |f, arg, want, got| {
                    if shown < a.show {
                        crate::outln!(
                            "  MISMATCH {} {f}({arg:e} = {:#018x}): libm {want:#018x}, vector \
                             {got:#018x}",
                            v.level(),
                            arg.to_bits()
                        );
                    }
                    shown += 1;
                });
            }
        }
        let mut row = vec![name.to_string(), super::group(args)];
        for t in &ts {
            total += t.sin + t.cos + t.sincos;
            row.extend([t.sin, t.cos, t.sincos].map(super::group));
        }
        row.push(what.to_string());
        crate::outln!("{}", cols.line(&row));
    }
    let secs = started.elapsed().as_secs_f64();
    crate::outln!(
        "{} arguments checked at {} in {secs:.1} s; {} differing results.",
        super::group(a.check + edges.len() as u64),
        level_names(levels),
        super::group(total)
    );
    Ok(total)
}

/// The levels' names, e.g. "avx2, avx512".
fn level_names(levels: &[Vector]) -> String {
    levels
        .iter()
        .map(|v| v.level().name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Counts of `n` split evenly over `ranges` (the remainder to the last).
fn split(n: u64, ranges: usize) -> impl Iterator<Item = u64> {
    let per = n / ranges as u64;
    (0..ranges).map(move |i| {
        if i + 1 == ranges {
            n - per * (ranges as u64 - 1)
        } else {
            per
        }
    })
}

/// Compares the port of glibc's `pow` alone (every argument in its range)
/// and `pow2_lanes` (fast path + port) of every vector level with libm over
/// the edge set and `--pow-check` random arguments; prints a table (two
/// counts per level); returns the number of differing results.
fn check_pow(levels: &[Vector], a: &LibmArgs) -> u64 {
    const CHUNK: usize = 1 << 16;
    let n = a.pow_check.unwrap_or(a.check);
    let cols = level_columns(&[(8, Align::Left), (14, Align::Right)], 2, 12, levels.len());
    crate::outln!(
        "\nBits of pow(x, 2), the port alone and pow2_lanes (fast path + port), each vector \
         level ({}) vs one libm pow call per argument:",
        level_names(levels)
    );
    let mut header = vec!["range".to_string(), "arguments".to_string()];
    header.extend(level_headers(levels, &["port", "lanes"]));
    header.push("what".into());
    crate::outln!("{}", cols.line(&header));
    let started = Instant::now();
    let (mut shown, mut total, mut checked) = (0, 0, 0u64);
    let (mut port, mut lanes, mut want) = (vec![0.0; CHUNK], vec![0.0; CHUNK], vec![0.0; CHUNK]);
    let mut sets: Vec<(&str, &str, u64)> = vec![(
        "edges",
        "fixed: ends, powers of 2, table edges, hard squares",
        0,
    )];
    for (r, k) in POW_RANGES.iter().zip(split(n, POW_RANGES.len())) {
        sets.push((r.name, r.what, k));
    }
    for (si, &(name, what, k)) in sets.iter().enumerate() {
        let mut rng = Rng::new(a.seed ^ (0x90 + si as u64) << 56);
        let mut done = 0u64;
        // Per level: differing results of the port and of pow2_lanes.
        let mut diff = vec![[0u64; 2]; levels.len()];
        loop {
            let x: Vec<f64> = if si == 0 {
                if done > 0 {
                    break;
                }
                lanes_math::pow2_edge_arguments()
            } else {
                if done >= k {
                    break;
                }
                let m = (k - done).min(CHUNK as u64) as usize;
                pow_args(&mut rng, &POW_RANGES[si - 1], m)
            };
            let m = x.len();
            done += m as u64;
            scalar::pow2_lanes(&x, &mut want[..m]);
            for (&v, [d_port, d_lanes]) in levels.iter().zip(&mut diff) {
                v.pow2_port_lanes(&x, &mut port[..m]);
                v.pow2_lanes(&x, &mut lanes[..m]);
                for i in 0..m {
                    let w = want[i].to_bits();
                    for (f, got, count) in [
                        ("port", port[i].to_bits(), &mut *d_port),
                        ("pow2_lanes", lanes[i].to_bits(), &mut *d_lanes),
                    ] {
                        if got != w && !(want[i].is_nan() && f64::from_bits(got).is_nan()) {
                            *count += 1;
                            if shown < a.show {
                                crate::outln!(
                                    "  MISMATCH {} {f}({:e} = {:#018x}): libm {w:#018x}, vector \
                                     {got:#018x}",
                                    v.level(),
                                    x[i],
                                    x[i].to_bits()
                                );
                            }
                            shown += 1;
                        }
                    }
                }
            }
        }
        checked += done;
        let mut row = vec![name.to_string(), super::group(done)];
        for d in &diff {
            total += d[0] + d[1];
            row.extend(d.map(super::group));
        }
        row.push(what.to_string());
        crate::outln!("{}", cols.line(&row));
    }
    crate::outln!(
        "{} arguments checked at {} in {:.1} s; {} differing results.",
        super::group(checked),
        level_names(levels),
        started.elapsed().as_secs_f64(),
        super::group(total)
    );
    total
}

/// Output buffers of one chunk.
struct Buffers {
    s: Vec<f64>,
    c: Vec<f64>,
    s2: Vec<f64>,
    c2: Vec<f64>,
    ws: Vec<f64>,
    wc: Vec<f64>,
}

impl Buffers {
    fn new(n: usize) -> Buffers {
        let z = || vec![0.0; n];
        Buffers {
            s: z(),
            c: z(),
            s2: z(),
            c2: z(),
            ws: z(),
            wc: z(),
        }
    }

    /// libm's `sin` and `cos` of `x`, for the following [`Buffers::compare`]s.
    fn libm(&mut self, x: &[f64]) {
        let n = x.len();
        scalar::sin_lanes(x, &mut self.ws[..n]);
        scalar::cos_lanes(x, &mut self.wc[..n]);
    }

    /// Vector level `v` vs libm (from [`Buffers::libm`] on the same `x`);
    /// `report(function, x, libm bits, vector bits)` for each differing
    /// result.
    fn compare(
        &mut self,
        v: Vector,
        x: &[f64],
        t: &mut Tally,
        mut report: impl FnMut(&str, f64, u64, u64),
    ) {
        let n = x.len();
        v.sin_lanes(x, &mut self.s[..n]);
        v.cos_lanes(x, &mut self.c[..n]);
        v.sincos_lanes(x, &mut self.s2[..n], &mut self.c2[..n]);
        for (i, &arg) in x.iter().enumerate() {
            let (ws, wc) = (self.ws[i].to_bits(), self.wc[i].to_bits());
            if self.s[i].to_bits() != ws {
                t.sin += 1;
                report("sin", arg, ws, self.s[i].to_bits());
            }
            if self.c[i].to_bits() != wc {
                t.cos += 1;
                report("cos", arg, wc, self.c[i].to_bits());
            }
            let (s2, c2) = (self.s2[i].to_bits(), self.c2[i].to_bits());
            if s2 != ws || c2 != wc {
                t.sincos += 1;
            }
            if s2 != ws {
                report("sincos.sin", arg, ws, s2);
            }
            if c2 != wc {
                report("sincos.cos", arg, wc, c2);
            }
        }
    }
}
