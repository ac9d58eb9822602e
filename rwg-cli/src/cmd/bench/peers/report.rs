//! What `rwg bench peers` measured and how it prints it: per workload, rwg's
//! measurements at each SIMD level, gymnax-raw's, the ratios paired by round
//! (each level over gymnax-raw, the last level over the first), the setup,
//! and the table.

use super::super::spread;
use super::{Part, PeerTime, Source};
use rwg_analysis::table::{Align, TextColumns};
use rwg_env::simd::Simd;
use serde::Serialize;

/// One side's measurements of one workload, in round order.
#[derive(Serialize, Debug, Default)]
pub(super) struct Side {
    pub(super) samples: u64,
    /// Env steps of each measurement.
    pub(super) env_steps: Vec<u64>,
    /// CPU seconds of each measurement (see the module doc of `peers` for
    /// what each side counts).
    pub(super) cpu_s: Vec<f64>,
    /// Wall seconds of each measurement (same span as `cpu_s`).
    pub(super) wall_s: Vec<f64>,
    /// `env_steps / cpu_s`, per measurement.
    pub(super) steps_per_cpu_s: Vec<f64>,
    /// Median of `steps_per_cpu_s`, and its range.
    pub(super) median: f64,
    pub(super) min: f64,
    pub(super) max: f64,
}

impl Side {
    /// A side of `samples` networks per measurement, nothing measured yet.
    pub(super) fn new(samples: u64) -> Side {
        Side {
            samples,
            ..Side::default()
        }
    }

    /// Adds one measurement.
    pub(super) fn push(&mut self, steps: u64, cpu: f64, wall: f64) {
        self.env_steps.push(steps);
        self.cpu_s.push(cpu);
        self.wall_s.push(wall);
        self.steps_per_cpu_s.push(steps as f64 / cpu);
        (self.median, self.min, self.max) = spread(&self.steps_per_cpu_s);
    }
}

/// Ratios of two sides' rates paired by round, with their median and range.
#[derive(Serialize, Debug, Default, PartialEq)]
pub(super) struct Ratio {
    pub(super) values: Vec<f64>,
    pub(super) median: f64,
    pub(super) min: f64,
    pub(super) max: f64,
}

impl Ratio {
    /// `a[i] / b[i]` for every round both have.
    fn of(a: &[f64], b: &[f64]) -> Ratio {
        let values: Vec<f64> = a.iter().zip(b).map(|(a, b)| a / b).collect();
        let (median, min, max) = spread(&values);
        Ratio {
            values,
            median,
            min,
            max,
        }
    }
}

/// rwg at one SIMD level on one workload.
#[derive(Serialize, Debug)]
pub(super) struct Level {
    /// The level every measurement below ran at (the child's `RWG_SIMD`).
    pub(super) simd: &'static str,
    #[serde(flatten)]
    pub(super) measured: Side,
    /// Per round: this level's steps/CPU-s over gymnax-raw's of the same round.
    pub(super) ratio: Ratio,
}

/// Per round: the last listed level's steps/CPU-s over the first's.
#[derive(Serialize, Debug, PartialEq)]
pub(super) struct LevelRatio {
    /// The last listed level (the numerator).
    pub(super) level: &'static str,
    /// The first listed level (the denominator).
    pub(super) over: &'static str,
    #[serde(flatten)]
    pub(super) ratio: Ratio,
}

/// One workload's comparison.
#[derive(Serialize, Debug)]
pub(super) struct Row {
    pub(super) env: String,
    pub(super) hidden: Vec<usize>,
    pub(super) episodes: u32,
    /// What gymnax-raw's CPU time counts (rwg's is always its whole run).
    pub(super) peer_time: PeerTime,
    /// rwg at each level of `--simd`, in the order listed.
    pub(super) rwg: Vec<Level>,
    pub(super) gymnax_raw: Side,
    /// The last level over the first (`null` for one level).
    pub(super) simd_ratio: Option<LevelRatio>,
    /// gymnax-raw's XLA compile seconds, per measurement (excluded above).
    pub(super) gymnax_compile_s: Vec<f64>,
}

impl Row {
    /// A workload of comparison `part` with nothing measured yet: rwg at
    /// `levels`.
    pub(super) fn new(
        env: &str,
        hidden: &[usize],
        episodes: u32,
        levels: &[Simd],
        part: Part,
    ) -> Row {
        let Part {
            rwg_samples,
            peer_samples,
            peer_time,
        } = part;
        Row {
            env: env.to_string(),
            hidden: hidden.to_vec(),
            episodes,
            peer_time,
            rwg: levels
                .iter()
                .map(|l| Level {
                    simd: l.name(),
                    measured: Side::new(rwg_samples),
                    ratio: Ratio::default(),
                })
                .collect(),
            gymnax_raw: Side::new(peer_samples),
            simd_ratio: None,
            gymnax_compile_s: vec![],
        }
    }

    /// `CartPole-v0 [4,4]`.
    pub(super) fn label(&self) -> String {
        format!("{} {}", self.env, hidden_label(&self.hidden))
    }

    /// How many networks each side ran: `10^4`, `3 x 10^4`, or `3 x 10^3 / 64`.
    pub(super) fn samples_label(&self) -> String {
        let n = |s: u64| {
            let e = (s as f64).log10().round() as u32;
            match 10u64.checked_pow(e).filter(|_| s >= 1000) {
                Some(p) if p == s => format!("10^{e}"),
                Some(p) if s.is_multiple_of(p) => format!("{} x 10^{e}", s / p),
                _ => s.to_string(),
            }
        };
        let (a, b) = (self.rwg[0].measured.samples, self.gymnax_raw.samples);
        if a == b {
            n(a)
        } else {
            format!("{} / {}", n(a), n(b))
        }
    }

    /// Recomputes the ratios from the measurements.
    pub(super) fn update_ratios(&mut self) {
        for l in &mut self.rwg {
            l.ratio = Ratio::of(
                &l.measured.steps_per_cpu_s,
                &self.gymnax_raw.steps_per_cpu_s,
            );
        }
        self.simd_ratio = match &self.rwg[..] {
            [first, .., last] => Some(LevelRatio {
                level: last.simd,
                over: first.simd,
                ratio: Ratio::of(
                    &last.measured.steps_per_cpu_s,
                    &first.measured.steps_per_cpu_s,
                ),
            }),
            _ => None,
        };
    }

    /// The last round's rates and ratios, for the progress line.
    pub(super) fn progress(&self) -> String {
        let last = |v: &[f64]| v.last().copied().unwrap_or(f64::NAN);
        let mut s = String::new();
        for l in &self.rwg {
            s += &format!("  {} {:.3e}", l.simd, last(&l.measured.steps_per_cpu_s));
        }
        s += &format!(
            "  gymnax-raw {:.3e}  ratio",
            last(&self.gymnax_raw.steps_per_cpu_s)
        );
        for l in &self.rwg {
            s += &format!(" {:.2}", last(&l.ratio.values));
        }
        if let Some(r) = &self.simd_ratio {
            s += &format!("  {} / {} {:.3}", r.level, r.over, last(&r.ratio.values));
        }
        s
    }
}

/// Where and how the comparison ran.
#[derive(Serialize)]
pub(super) struct Setup {
    pub(super) date_utc: String,
    pub(super) cpu_model: String,
    pub(super) cpus: usize,
    pub(super) pinned_cpu: Option<usize>,
    pub(super) load_avg_start: String,
    pub(super) load_avg_end: String,
    pub(super) rounds: u32,
    pub(super) seed: u64,
    /// rwg's envs: the built-in ones or gymnax's as `gymnax:` envs.
    pub(super) source: Source,
    /// rwg's SIMD levels measured, in the order of `--simd`.
    pub(super) simd_levels: Vec<&'static str>,
    pub(super) rwg_binary: String,
    pub(super) rwg_command: String,
    pub(super) peer_command: String,
}

/// Everything `rwg bench peers --json` prints.
#[derive(Serialize)]
pub(super) struct Report {
    pub(super) setup: Setup,
    pub(super) rows: Vec<Row>,
}

/// `[]` -> `0HL`, `[4, 4]` -> `[4,4]`.
fn hidden_label(h: &[usize]) -> String {
    if h.is_empty() {
        "0HL".into()
    } else {
        let v: Vec<String> = h.iter().map(|x| x.to_string()).collect();
        format!("[{}]", v.join(","))
    }
}

/// The table's header and rows: the workload, its networks (rwg's /
/// gymnax-raw's) and what gymnax-raw's time counts, rwg at each level,
/// gymnax-raw, each level over gymnax-raw, and the last level over the
/// first (with more than one level).
fn table_cells(rows: &[Row], source: Source, levels: &[&str]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut header = vec![
        "workload".to_string(),
        "networks".to_string(),
        "gymnax-raw counts".to_string(),
    ];
    header.extend(levels.iter().map(|l| source.column(l)));
    header.push("gymnax-raw".into());
    header.extend(levels.iter().map(|l| match source {
        Source::Builtin => format!("{l} / gymnax-raw"),
        Source::Gymnax => "rwg / gymnax-raw".to_string(),
    }));
    if let [first, .., last] = levels {
        header.push(format!("{last} / {first}"));
    }
    let rate = |s: &Side| format!("{:.3e} [{:.2e}-{:.2e}]", s.median, s.min, s.max);
    let ratio = |r: &Ratio| format!("{:.2}x [{:.2}-{:.2}]", r.median, r.min, r.max);
    let fine = |r: &Ratio| format!("{:.3}x [{:.3}-{:.3}]", r.median, r.min, r.max);
    let body = rows
        .iter()
        .map(|row| {
            let mut cells = vec![
                row.label(),
                row.samples_label(),
                row.peer_time.label().to_string(),
            ];
            cells.extend(row.rwg.iter().map(|l| rate(&l.measured)));
            cells.push(rate(&row.gymnax_raw));
            cells.extend(row.rwg.iter().map(|l| ratio(&l.ratio)));
            cells.extend(row.simd_ratio.iter().map(|r| fine(&r.ratio)));
            cells
        })
        .collect();
    (header, body)
}

/// Prints the human-readable report.
pub(super) fn print_table(r: &Report) {
    let s = &r.setup;
    crate::outln!(
        "rwg bench peers, {} UTC, {} ({} CPUs), {}, {} rounds, load average {} -> {}",
        s.date_utc,
        s.cpu_model,
        s.cpus,
        s.pinned_cpu
            .map_or("not pinned".into(), |c| format!("pinned to CPU {c}")),
        s.rounds,
        s.load_avg_start,
        s.load_avg_end
    );
    match s.source {
        Source::Builtin => crate::outln!(
            "rwg:        {}, at RWG_SIMD={}",
            s.rwg_command,
            s.simd_levels.join(", ")
        ),
        Source::Gymnax => crate::outln!("rwg:        {}", s.rwg_command),
    }
    crate::outln!("gymnax-raw: {}", s.peer_command);
    crate::outln!(
        "env steps per CPU-second, median [min-max]; rwg: its whole process; gymnax-raw: its \
         whole process, or its compiled run alone (start-up and compilation excluded), as each \
         row says; ratios paired by round\n"
    );
    let (header, body) = table_cells(&r.rows, s.source, &s.simd_levels);
    let columns: Vec<(usize, Align)> = (0..header.len())
        .map(|i| {
            let width = body
                .iter()
                .map(|cells| cells[i].chars().count())
                .chain([header[i].chars().count()])
                .max()
                .unwrap_or(0);
            (width, if i < 3 { Align::Left } else { Align::Right })
        })
        .collect();
    let columns = TextColumns::new(&columns, "  ");
    crate::outln!("{}", columns.line(&header));
    for cells in &body {
        crate::outln!("{}", columns.line(cells));
    }
}

/// The CPU's model name, where /proc/cpuinfo tells it.
pub(super) fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, m)| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The 1, 5 and 15-minute load averages, where /proc/loadavg tells them.
pub(super) fn load_avg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".into())
}

/// The current UTC time as `YYYY-MM-DD HH:MM`.
pub(super) fn now_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    let s = secs % 86_400;
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}", s / 3600, s / 60 % 60)
}

/// Days since 1970-01-01 -> (year, month, day) in the proleptic Gregorian
/// calendar (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Pendulum-v1 [4] row measured over three rounds: rwg at `levels`
    /// with `rwg[k]` steps per CPU-second in each round (one CPU-second
    /// each), gymnax-raw with 5, 10 and 20.
    fn measured(levels: &[Simd], rwg: &[[u64; 3]]) -> Row {
        let part = Part {
            rwg_samples: 30,
            peer_samples: 10,
            peer_time: PeerTime::Compiled,
        };
        let mut row = Row::new("Pendulum-v1", &[4], 20, levels, part);
        for round in 0..3 {
            for (l, rates) in row.rwg.iter_mut().zip(rwg) {
                l.measured.push(rates[round], 1.0, 1.0);
            }
            row.gymnax_raw.push([5, 10, 20][round], 1.0, 2.0);
        }
        row.update_ratios();
        row
    }

    #[test]
    fn ratios_are_paired_by_round() {
        let row = measured(&[Simd::Scalar], &[[10, 30, 20]]);
        let l = &row.rwg[0];
        assert_eq!(l.simd, "scalar");
        assert_eq!(l.measured.steps_per_cpu_s, [10.0, 30.0, 20.0]);
        assert_eq!(
            (l.measured.median, l.measured.min, l.measured.max),
            (20.0, 10.0, 30.0)
        );
        assert_eq!(row.gymnax_raw.median, 10.0);
        assert_eq!(row.gymnax_raw.wall_s, [2.0, 2.0, 2.0]);
        assert_eq!(l.ratio.values, [2.0, 3.0, 1.0]);
        assert_eq!((l.ratio.median, l.ratio.min, l.ratio.max), (2.0, 1.0, 3.0));
        assert_eq!(row.simd_ratio, None);
    }

    #[test]
    fn each_level_has_its_ratio_and_the_last_is_over_the_first() {
        let levels = [Simd::Avx2, Simd::Scalar, Simd::Avx512];
        let row = measured(&levels, &[[10, 30, 20], [5, 5, 5], [40, 30, 10]]);
        let names: Vec<&str> = row.rwg.iter().map(|l| l.simd).collect();
        assert_eq!(names, ["avx2", "scalar", "avx512"]);
        assert_eq!(row.rwg[0].ratio.values, [2.0, 3.0, 1.0]);
        assert_eq!(row.rwg[1].ratio.values, [1.0, 0.5, 0.25]);
        assert_eq!(row.rwg[2].ratio.values, [8.0, 3.0, 0.5]);
        let r = row.simd_ratio.as_ref().unwrap();
        assert_eq!((r.level, r.over), ("avx512", "avx2"));
        assert_eq!(r.ratio.values, [4.0, 1.0, 0.5]);
        assert_eq!((r.ratio.median, r.ratio.min, r.ratio.max), (1.0, 0.5, 4.0));
        // The JSON keeps every measurement beside its level.
        let v = serde_json::to_value(&row).unwrap();
        assert_eq!(v["rwg"][2]["simd"], "avx512");
        assert_eq!(v["rwg"][2]["steps_per_cpu_s"][0], 40.0);
        assert_eq!(v["rwg"][2]["ratio"]["values"][1], 3.0);
        assert_eq!(v["simd_ratio"]["over"], "avx2");
        assert_eq!(v["simd_ratio"]["median"], 1.0);
        assert_eq!(
            row.progress().matches(" / ").count(),
            1,
            "{}",
            row.progress()
        );
    }

    #[test]
    fn the_table_has_a_column_per_level_and_their_ratio() {
        let levels = [Simd::Avx2, Simd::Avx512];
        let rows = [measured(&levels, &[[10, 30, 20], [40, 30, 10]])];
        let (header, body) = table_cells(&rows, Source::Builtin, &["avx2", "avx512"]);
        assert_eq!(
            header,
            [
                "workload",
                "networks",
                "gymnax-raw counts",
                "rwg avx2",
                "rwg avx512",
                "gymnax-raw",
                "avx2 / gymnax-raw",
                "avx512 / gymnax-raw",
                "avx512 / avx2"
            ]
        );
        assert_eq!(body[0][..3], ["Pendulum-v1 [4]", "30 / 10", "compiled run"]);
        assert_eq!(body[0][3], "2.000e1 [1.00e1-3.00e1]");
        assert_eq!(body[0][6], "2.00x [1.00-3.00]");
        assert_eq!(body[0][8], "1.000x [0.500-4.000]");
        let one = [measured(&[Simd::Scalar], &[[10, 30, 20]])];
        let (header, body) = table_cells(&one, Source::Builtin, &["scalar"]);
        assert_eq!(header.len(), 6);
        assert_eq!(body[0].len(), 6);
        let (header, _) = table_cells(&one, Source::Gymnax, &["scalar"]);
        assert_eq!(
            header,
            [
                "workload",
                "networks",
                "gymnax-raw counts",
                "rwg gymnax:",
                "gymnax-raw",
                "rwg / gymnax-raw"
            ]
        );
    }

    #[test]
    fn networks_are_said_in_powers_of_ten_where_they_are_one() {
        let row = |rwg: u64, peer: u64, peer_time| {
            let part = Part {
                rwg_samples: rwg,
                peer_samples: peer,
                peer_time,
            };
            Row::new("gymnax:Acrobot-v1", &[], 20, &[Simd::Scalar], part)
        };
        let whole = row(10_000, 10_000, PeerTime::Whole);
        assert_eq!(whole.samples_label(), "10^4");
        assert_eq!(whole.peer_time.label(), "whole process");
        assert_eq!(
            row(30_000, 30_000, PeerTime::Compiled).samples_label(),
            "3 x 10^4"
        );
        assert_eq!(
            row(3000, 64, PeerTime::Compiled).samples_label(),
            "3 x 10^3 / 64"
        );
    }

    #[test]
    fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(19_723), (2024, 1, 1));
        assert_eq!(civil_from_days(20_780), (2026, 11, 23));
    }
}
