//! The two episode loops of a JAX cell, end to end with the real `rwg`
//! binary: an env whose episodes all end at the same step whatever the
//! actions runs the plain loop, one whose `done` depends on the actions or
//! on what its reset draws runs the refilling lanes; the run's first lines
//! and each cell's `env.json` say which, and why. That both loops give the
//! same bits is `cli_jax_examples.rs`' replay of a Pendulum study (plain)
//! by the lanes' program. And the workers' lives across envs: a study of
//! two JAX envs holds one env's workers at a time.
//!
//! Needs `RWG_PEER_PYTHON` (see `cli_jax.rs`).

mod common;
mod jax_common;
use common::*;
use jax_common::*;

/// (loop, why) of the cell's `env.json`, and its episodes' lengths.
fn loop_and_lengths(cell: &std::path::Path) -> (String, String, Vec<u32>) {
    let env: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cell.join("env.json")).unwrap()).unwrap();
    let l = &env["jax"]["episode_loop"];
    let scores = std::fs::read_to_string(cell.join("scores.csv")).unwrap();
    let lengths = scores
        .lines()
        .skip(1)
        .map(|row| row.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    (
        l["loop"].as_str().unwrap_or_default().to_string(),
        l["why"].as_str().unwrap_or_default().to_string(),
        lengths,
    )
}

/// A countdown of 5 steps runs the plain loop, every episode 5 steps; a
/// countdown the reset draws from 3 to 9 runs the lanes, and its episodes
/// have those lengths.
#[test]
fn a_fixed_length_env_runs_the_plain_loop_and_a_drawn_length_the_lanes() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-loops");
    for (drawn, want, why) in [
        (false, "plain", "every episode ends at the same step"),
        (true, "lanes", "its episodes end on what its reset draws"),
    ] {
        let entry = format!("kwargs = {{ drawn = {drawn} }}");
        let m = write(
            &dir,
            &format!("m-{drawn}.toml"),
            &manifest(&py, "jax:rwg_jax_envs:make_timer", &entry, 64, 4, false),
        );
        let run = dir.join(format!("run-{drawn}"));
        let out = rwg_cmd(&["run", &m, "--out", s(&run), "--threads", "1"])
            .output()
            .unwrap();
        let text = output_text(&out);
        assert!(out.status.success(), "{text}");
        let line = if drawn {
            "512 lanes (an ended lane takes the next episode)"
        } else {
            "512 lanes (run together to the end: every episode ends at the same step"
        };
        assert!(text.contains(line), "{text}");
        let cell = run.join("cells/jax=rwg_jax_envs=make_timer__0HL__nobias");
        let (kind, reason, lengths) = loop_and_lengths(&cell);
        assert_eq!((kind.as_str(), lengths.len()), (want, 64 * 4), "{reason}");
        assert!(reason.starts_with(why), "{reason}");
        if drawn {
            assert!(lengths.iter().all(|l| (3..=9).contains(l)), "{lengths:?}");
            let distinct: std::collections::BTreeSet<_> = lengths.iter().collect();
            assert!(distinct.len() >= 5, "{lengths:?}");
        } else {
            assert!(lengths.iter().all(|&l| l == 5), "{lengths:?}");
        }
    }
    // an env that ends on what its actions do runs the lanes
    let m = write(
        &dir,
        "slider.toml",
        &manifest(&py, "jax:rwg_jax_envs:make_slider", "", 32, 2, false),
    );
    let run = dir.join("run-slider");
    ok(&["run", &m, "--out", s(&run), "--threads", "1"]);
    let (kind, reason, _) =
        loop_and_lengths(&run.join("cells/jax=rwg_jax_envs=make_slider__0HL__nobias"));
    assert_eq!(kind, "lanes", "{reason}");
    assert!(reason.contains("what the actions do"), "{reason}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A study of two JAX envs holds one env's workers at a time: the second
/// env's worker made at planning ends before the first env's cells run,
/// the first env's workers end after its last cell, and the second env's
/// cells start workers of their own while none of the first's runs.
#[test]
fn a_study_of_two_jax_envs_ends_each_env_s_workers_after_its_cells() {
    let Some(py) = python() else { return };
    let dir = temp_dir("jax-workers");
    let (a, b) = (dir.join("a.log"), dir.join("b.log"));
    let m = write(
        &dir,
        "m.toml",
        &format!(
            "{}\n[[envs]]\nid = \"jax:rwg_jax_envs:make_watcher\"\npython = {py:?}\n\
             kwargs = {{ log = {:?}, watch = {:?} }}\n",
            manifest(
                &py,
                "jax:rwg_jax_envs:make_witness",
                &format!("kwargs = {{ log = {:?} }}", s(&a)),
                64,
                2,
                false
            ),
            s(&b),
            s(&a)
        ),
    );
    let run = dir.join("run");
    let out = rwg_cmd(&["run", &m, "--out", s(&run), "--threads", "2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", output_text(&out));
    let lines = |p: &std::path::Path| -> Vec<Vec<u32>> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .map(|l| l.split_whitespace().map(|w| w.parse().unwrap()).collect())
            .collect()
    };
    let (a, b) = (lines(&a), lines(&b));
    // the first env: its planning worker, and one for the second thread
    assert!((1..=2).contains(&a.len()), "{a:?}");
    // the second env: made at planning, that worker ended before the first
    // env's cell ran, then made by the two workers of its own cell (two
    // chunks of 32 networks on two threads), when none of the first's ran
    assert_eq!(b.len(), 3, "{b:?}");
    for made in &b[1..] {
        assert_eq!(made.len(), 1, "the first env's workers still ran: {b:?}");
    }
}
