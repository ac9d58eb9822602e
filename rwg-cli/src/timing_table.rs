//! The table `rwg run --timing` prints: the phases of every cell
//! (`rwg_study::timing`; a JAX cell's sampling split into its compile and
//! its run), then the run's totals and serial share.

use rwg_analysis::table::{Align, TextColumns};
use rwg_study::timing::{share, RunTiming};
use std::time::Duration;

/// The phases of `t` as a table; `report`: the analysis' time if the run
/// wrote it. Left of `|`, a cell's wall time on the runner's thread
/// (sampling, of which a JAX cell's compile and run, serial time and
/// share); right of it, the cell's end, overlapped with the next cell's
/// sampling.
pub fn timing_table(t: &RunTiming, report: Option<Duration>) -> String {
    let ms = |d: Duration| format!("{:.1}", d.as_secs_f64() * 1e3);
    let columns = TextColumns::new(
        &[
            (44, Align::Left),
            (10, Align::Right),
            (9, Align::Right),
            (10, Align::Right),
            (10, Align::Right),
            (7, Align::Right),
            (1, Align::Left),
            (10, Align::Right),
            (10, Align::Right),
            (10, Align::Right),
            (9, Align::Right),
        ],
        " ",
    );
    let mut s = columns.line(&[
        "phase (wall ms)",
        "sampling",
        "compile",
        "run",
        "serial",
        "serial",
        "|",
        "commit I/O",
        "commit end",
        "finalise",
        "run.json",
    ]) + "\n";
    for c in &t.cells {
        s += &columns.line(&[
            c.dir.clone(),
            ms(c.sampling),
            c.warm_up.map_or_else(|| "-".into(), ms),
            c.warm_up
                .map_or_else(|| "-".into(), |w| ms(c.sampling.saturating_sub(w))),
            ms(c.serial),
            format!("{:.2}%", 100.0 * c.serial_share()),
            "|".into(),
            ms(c.commit_io),
            ms(c.commit_end),
            ms(c.finalize),
            ms(c.run_json),
        ]);
        s.push('\n');
    }
    let report = report.unwrap_or_default();
    let sum = t.cells_sum();
    if sum.warm_up.is_some() {
        s += "(compile, run: a JAX cell's sampling: its workers starting and compiling the cell \
              until the last is ready, then running it)\n";
    }
    s += "(right of |: the cell's end, overlapped with the next cell's sampling, not part of its wall time)\n";
    let (serial, total) = t.serial_and_total(report);
    let split = sum.warm_up.map_or_else(String::new, |w| {
        format!(
            " (JAX compile {} ms, run {} ms)",
            ms(w),
            ms(t.cells
                .iter()
                .filter_map(|c| c.warm_up.map(|w| c.sampling.saturating_sub(w)))
                .sum())
        )
    });
    s += &format!(
        "cells: sampling {} ms{split}, serial {} ms; set-up {} ms, last cells' ends {} ms, \
         wrap-up {} ms, report {} ms\n",
        ms(sum.sampling),
        ms(sum.serial),
        ms(t.setup),
        ms(t.drain),
        ms(t.wrap_up),
        ms(report)
    );
    s += &format!(
        "whole run: {} ms, serial share {:.2}% (cells alone {:.2}%)\n",
        ms(total),
        100.0 * share(serial, total),
        100.0 * sum.serial_share()
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_study::timing::CellTiming;

    #[test]
    fn one_line_per_cell_then_the_totals() {
        let c = CellTiming {
            dir: "CartPole-v0__0HL__nobias".into(),
            sampling: Duration::from_millis(900),
            warm_up: None,
            serial: Duration::from_millis(100),
            commit_io: Duration::from_millis(500),
            commit_end: Duration::from_millis(60),
            finalize: Duration::from_millis(30),
            run_json: Duration::from_millis(10),
        };
        let t = RunTiming {
            setup: Duration::from_millis(50),
            cells: vec![c],
            drain: Duration::from_millis(40),
            wrap_up: Duration::from_millis(10),
        };
        let table = timing_table(&t, Some(Duration::from_millis(50)));
        let lines: Vec<&str> = table.lines().collect();
        let header = format!(
            "{:<44} {:>10} {:>9} {:>10} {:>10} {:>7} | {:>10} {:>10} {:>10} {:>9}",
            "phase (wall ms)",
            "sampling",
            "compile",
            "run",
            "serial",
            "serial",
            "commit I/O",
            "commit end",
            "finalise",
            "run.json"
        );
        assert_eq!(lines[0], header);
        let row = format!(
            "{:<44} {:>10} {:>9} {:>10} {:>10} {:>6.2}% | {:>10} {:>10} {:>10} {:>9}",
            "CartPole-v0__0HL__nobias",
            "900.0",
            "-",
            "-",
            "100.0",
            10.0,
            "500.0",
            "60.0",
            "30.0",
            "10.0"
        );
        assert_eq!(lines[1], row);
        assert!(lines[2].starts_with("(right of |"), "{}", lines[2]);
        assert_eq!(
            lines[3],
            "cells: sampling 900.0 ms, serial 100.0 ms; set-up 50.0 ms, last cells' ends 40.0 ms, \
             wrap-up 10.0 ms, report 50.0 ms"
        );
        // (50 + 100 + 40 + 10 + 50) / 1150
        assert_eq!(
            lines[4],
            "whole run: 1150.0 ms, serial share 21.74% (cells alone 10.00%)"
        );
        assert_eq!(lines.len(), 5);
    }

    #[test]
    fn a_jax_cell_shows_its_compile_and_its_run() {
        let mut c = CellTiming {
            dir: "gymnax=CartPole-v1__0HL__nobias".into(),
            sampling: Duration::from_millis(900),
            warm_up: Some(Duration::from_millis(700)),
            ..CellTiming::default()
        };
        let builtin = CellTiming {
            dir: "CartPole-v1__0HL__nobias".into(),
            sampling: Duration::from_millis(100),
            ..CellTiming::default()
        };
        let t = RunTiming {
            cells: vec![c.clone(), builtin],
            ..RunTiming::default()
        };
        let table = timing_table(&t, None);
        let lines: Vec<&str> = table.lines().collect();
        assert!(
            lines[1].starts_with(&format!(
                "{:<44} {:>10} {:>9} {:>10}",
                c.dir, "900.0", "700.0", "200.0"
            )),
            "{table}"
        );
        assert!(lines[2].contains("   -          -"), "{table}");
        assert!(
            lines[3].starts_with("(compile, run: a JAX cell's sampling"),
            "{table}"
        );
        assert!(
            lines[5].starts_with("cells: sampling 1000.0 ms (JAX compile 700.0 ms, run 200.0 ms)"),
            "{table}"
        );
        // a warm-up longer than the sampling clock (clock reads apart) runs 0
        c.warm_up = Some(Duration::from_millis(950));
        let t = RunTiming {
            cells: vec![c],
            ..RunTiming::default()
        };
        assert!(timing_table(&t, None)
            .lines()
            .nth(1)
            .unwrap()
            .contains(" 950.0        0.0 "));
    }
}
