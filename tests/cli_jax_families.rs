//! The JAX env families (`playground:`, `jumanji:`, `craftax:`, `navix:`,
//! `xminigrid:`, `pgx:`) end to end with the real `rwg` binary: per family,
//! the bytes of `scores.csv`, `samples.csv` and `stats.csv` are the same for
//! a run on 2 threads (two workers), two shards each on 1 thread merged, and
//! a run stopped by Ctrl-C after its first block and resumed (Jumanji,
//! Navix, XLand-MiniGrid, Pgx); `env.json`
//! records the observation's leaves, the legal-action mask and the choices
//! made for the env; the families' refusals and an import that fails for a
//! reason other than a missing package say what is wrong. Playground and
//! Craftax, whose first compiles take from half a minute to two on a CPU,
//! run one small study each.
//!
//! Needs `RWG_PEER_PYTHON` with the six families installed (`.ci/run` makes
//! one); without it each test prints `SKIPPED` (and fails under `CI=true`
//! or `RWG_NO_SKIP=1`).

mod common;
mod jax_common;
use common::*;
use jax_common::*;
use std::path::Path;

/// The `jax` part of the env.json of `run`'s only cell.
fn jax_record(run: &Path) -> serde_json::Value {
    let cell = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let text = std::fs::read_to_string(cell.join("env.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["jax"].clone()
}

/// A study of env `id` (entry lines `entry`): 1024 networks x 2 episodes in
/// calls of 32, run on 2 threads, as two shards on 1 thread merged, and
/// stopped by Ctrl-C after its first block then resumed; the three give the
/// same bytes. Returns the 2-thread run's `env.json` record and its
/// `scores.csv`.
fn same_bytes_every_way(name: &str, id: &str, entry: &str) -> Option<(serde_json::Value, String)> {
    let py = python()?;
    let dir = temp_dir(name);
    // 32 calls of 32 networks: the run goes on after its first block, so Ctrl-C
    // lands before its end
    let body = manifest(
        &py,
        id,
        &format!("networks_per_call = 32\n{entry}"),
        1024,
        2,
        false,
    );
    let m = write(&dir, "m.toml", &body);
    let run = |out: &str, extra: &[&str]| {
        let out = dir.join(out);
        let mut args = vec!["run", &m, "--out", s(&out)];
        args.extend_from_slice(extra);
        ok(&args);
        out
    };
    let t2 = run("t2", &["--threads", "2"]);
    let s0 = run("s0", &["--shard", "0/2", "--threads", "1"]);
    let s1 = run("s1", &["--shard", "1/2", "--threads", "1"]);
    let merged = dir.join("merged");
    ok(&["merge", s(&s0), s(&s1), "--out", s(&merged)]);
    assert_same(&t2, &merged);

    let stopped = dir.join("stopped");
    let mut cmd = rwg_cmd(&[
        "run",
        &m,
        "--out",
        s(&stopped),
        "--threads",
        "1",
        "--no-report",
    ]);
    cmd.env("RWG_COMMIT_LINGER", "0");
    let cell = id.replace(':', "=");
    let first = stopped.join(format!("cells/{cell}__0HL__nobias/blocks/b0000000.csv"));
    // (a worker's start and compile take a while on a loaded machine)
    let res = ctrl_c_when(cmd, &first, std::time::Duration::from_secs(600));
    let e = String::from_utf8_lossy(&res.stderr);
    assert_eq!(res.status.code(), Some(130), "{e}");
    assert!(first.is_file(), "{e}");
    run("stopped", &["--threads", "1"]);
    assert_same(&t2, &stopped);
    let record = jax_record(&t2);
    let scores =
        std::fs::read_to_string(t2.join(format!("cells/{cell}__0HL__nobias/scores.csv"))).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    Some((record, scores))
}

fn leaves(record: &serde_json::Value) -> Vec<(String, String)> {
    record["observation_leaves"]
        .as_array()
        .unwrap_or_else(|| panic!("no leaves in {record}"))
        .iter()
        .map(|l| {
            (
                l["name"].as_str().unwrap().to_string(),
                format!("{}{}", l["dtype"], l["shape"]),
            )
        })
        .collect()
}

/// Jumanji's Snake: a named-tuple observation without its `action_mask`
/// field, the argmax over legal actions.
#[test]
fn jumanji_snake_is_the_same_every_way_with_its_legal_actions() {
    let entry = "max_episode_steps = 15";
    let Some((r, _)) = same_bytes_every_way("fam-jumanji", "jumanji:Snake-v1", entry) else {
        return;
    };
    assert_eq!(
        leaves(&r),
        [
            ("grid".into(), "\"float32\"[12,12,5]".into()),
            ("step_count".into(), "\"int32\"[]".into())
        ],
        "{r}"
    );
    assert_eq!(r["action_mask"], "legal", "{r}");
    assert_eq!(r["versions"]["jumanji"], "1.1.2", "{r}");
}

/// Craftax-Classic (symbolic), without auto-reset: one small study (its
/// first compile takes a minute or more on a CPU; it is stepped as gymnax
/// envs are, whose bytes `cli_jax.rs` checks every way).
#[test]
fn a_craftax_classic_study_runs_without_auto_reset() {
    let Some(py) = python() else { return };
    let dir = temp_dir("fam-craftax");
    let entry = "max_episode_steps = 10\nnetworks_per_call = 32";
    let id = "craftax:Craftax-Classic-Symbolic-v1";
    let m = write(&dir, "m.toml", &manifest(&py, id, entry, 32, 1, false));
    let run = dir.join("run");
    ok(&["run", &m, "--out", s(&run), "--no-report", "--threads", "1"]);
    let r = jax_record(&run);
    assert_eq!(
        leaves(&r),
        [("obs".into(), "\"float32\"[1345]".into())],
        "{r}"
    );
    assert_eq!(r["settings"]["auto_reset"], "false", "{r}");
    assert_eq!(r["action_mask"], "none", "{r}");
    assert_eq!(r["versions"]["craftax"], "1.6.1", "{r}");
    // Craftax's spaces have no repr of their own: env.json records their
    // fields, not an address that differs in the next process (the same
    // command again finds the study complete instead of "another env")
    let cell = run.join("cells/craftax=Craftax-Classic-Symbolic-v1__0HL__nobias/env.json");
    let env_json = std::fs::read_to_string(cell).unwrap();
    assert!(!env_json.contains(" object at 0x"), "{env_json}");
    let again = ok(&["run", &m, "--out", s(&run), "--no-report", "--threads", "1"]);
    assert!(again.contains("complete"), "{again}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Navix: a uint8 grid observation.
#[test]
fn navix_is_the_same_every_way() {
    let id = "navix:Navix-DoorKey-5x5-v0";
    let Some((r, _)) = same_bytes_every_way("fam-navix", id, "max_episode_steps = 20") else {
        return;
    };
    assert_eq!(r["versions"]["navix"], "0.7.4", "{r}");
    assert_eq!(leaves(&r).len(), 1, "{r}");
}

/// XLand-MiniGrid: reset(params, key), a uint8 view.
#[test]
fn xland_minigrid_is_the_same_every_way() {
    let id = "xminigrid:MiniGrid-EmptyRandom-6x6";
    let Some((r, _)) = same_bytes_every_way("fam-xland", id, "max_episode_steps = 20") else {
        return;
    };
    assert_eq!(
        leaves(&r),
        [("obs".into(), "\"uint8\"[7,7,2]".into())],
        "{r}"
    );
    assert_eq!(r["action_mask"], "none", "{r}");
}

/// Pgx's 2048 with its legal actions; `action_mask = false` is another
/// study, recorded as `off`; a multi-player game is refused naming why.
#[test]
fn pgx_2048_is_the_same_every_way_and_masks_can_be_turned_off() {
    let entry = "max_episode_steps = 40";
    let Some((r, legal)) = same_bytes_every_way("fam-pgx", "pgx:2048", entry) else {
        return;
    };
    assert_eq!(
        leaves(&r),
        [("obs".into(), "\"bool\"[4,4,31]".into())],
        "{r}"
    );
    assert_eq!(r["action_mask"], "legal", "{r}");
    let py = python().unwrap();
    let dir = temp_dir("fam-pgx-off");
    let m = write(
        &dir,
        "m.toml",
        &manifest(
            &py,
            "pgx:2048",
            "max_episode_steps = 40\naction_mask = false",
            32,
            1,
            false,
        ),
    );
    let off = dir.join("off");
    ok(&["run", &m, "--out", s(&off), "--no-report"]);
    assert_eq!(jax_record(&off)["action_mask"], "off");
    let saved = std::fs::read_to_string(off.join("manifest.toml")).unwrap();
    assert!(saved.contains("action_mask = false"), "{saved}");
    // network n's episode 0 has the same weights and reset seed in both: with
    // the mask it never plays an illegal move; without, Pgx ends the game at
    // the first one (reward -1), so some episodes are shorter
    let rows = |text: &str| -> Vec<(String, u32)> {
        text.lines()
            .skip(1)
            .filter(|l| l.split(',').nth(1) == Some("0"))
            .take(32)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                (f[2].to_string(), f[3].parse().unwrap())
            })
            .collect()
    };
    let off_scores =
        std::fs::read_to_string(off.join("cells/pgx=2048__0HL__nobias/scores.csv")).unwrap();
    let (with, without) = (rows(&legal), rows(&off_scores));
    assert_eq!((with.len(), without.len()), (32, 32));
    assert!(
        with.iter().zip(&without).any(|(w, o)| o.1 < w.1),
        "no game ended sooner without the mask: {with:?} {without:?}"
    );
    assert!(
        with.iter().zip(&without).all(|(w, o)| o.1 <= w.1),
        "a game lasted longer without the mask: {with:?} {without:?}"
    );

    let e = err(&["envs", "pgx:tic_tac_toe", "--python", &py]);
    assert!(e.contains("game of 2 players") && e.contains("2048"), "{e}");
    let e = err(&["envs", "pgx:2049", "--python", &py]);
    assert!(
        e.contains("Pgx has no environment '2049'") && e.contains("minatar-breakout"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// One small Playground study: DM Control's CartpoleBalance on MJX's JAX
/// physics (Playground's default is Warp), recorded in env.json.
#[test]
fn a_playground_study_runs_on_jax_physics() {
    let Some(py) = python() else { return };
    let dir = temp_dir("fam-playground");
    let entry = "max_episode_steps = 10\nnetworks_per_call = 32";
    let m = write(
        &dir,
        "m.toml",
        &manifest(&py, "playground:CartpoleBalance", entry, 32, 1, false),
    );
    let run = dir.join("run");
    ok(&["run", &m, "--out", s(&run), "--no-report", "--threads", "1"]);
    let r = jax_record(&run);
    assert_eq!(r["settings"]["impl"], "jax", "{r}");
    assert_eq!(r["versions"]["playground"], "0.2.0", "{r}");
    assert_eq!(leaves(&r), [("obs".into(), "\"float32\"[5]".into())], "{r}");
    let scores = std::fs::read_to_string(
        run.join("cells/playground=CartpoleBalance__0HL__nobias/scores.csv"),
    )
    .unwrap();
    assert_eq!(scores.lines().count(), 33, "{scores}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A family installed but failing to import is reported with the import's
/// reason, not as "not installed"; an unknown id lists the family's ids.
#[test]
fn a_family_that_fails_to_import_says_why() {
    let Some(py) = python() else { return };
    let dir = temp_dir("fam-import");
    let pkg = dir.join("navix");
    std::fs::create_dir_all(&pkg).unwrap();
    std::fs::write(pkg.join("__init__.py"), "import rwg_no_such_module_xyz\n").unwrap();
    let out = rwg_cmd(&["envs", "navix:Navix-Empty-5x5-v0", "--python", &py])
        .env("PYTHONPATH", &dir)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{e}");
    assert!(e.contains("Navix is installed for"), "{e}");
    assert!(
        e.contains("No module named 'rwg_no_such_module_xyz'"),
        "{e}"
    );
    assert!(!e.contains("is not installed"), "{e}");

    let e = err(&["envs", "jumanji:Snake-v9", "--python", &py]);
    assert!(e.contains("Jumanji has no environment 'Snake-v9'"), "{e}");
    assert!(e.contains("Snake-v1") && e.contains("Game2048-v1"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Assets a library downloads on first use are named at start when they are
/// missing: Playground's locomotion robots (MuJoCo Menagerie) and an XLand
/// benchmark's rulesets.
#[test]
fn missing_assets_are_named_at_start() {
    let Some(py) = python() else { return };
    let dir = temp_dir("fam-assets");
    let e = err(&["envs", "playground:Go1JoystickFlatTerrain", "--python", &py]);
    assert!(
        e.contains("MuJoCo Menagerie") && e.contains("mujoco_menagerie"),
        "{e}"
    );
    assert!(e.contains("commit"), "{e}");
    let out = rwg_cmd(&[
        "envs",
        "xminigrid:XLand-MiniGrid-R1-9x9",
        "--python",
        &py,
        "--kwargs",
        r#"{"benchmark": "trivial-21k", "ruleset": 0}"#,
    ])
    .env("XLAND_MINIGRID_DATA", &dir)
    .output()
    .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{e}");
    assert!(e.contains("benchmark 'trivial-21k' is not at"), "{e}");
    assert!(e.contains("XLAND_MINIGRID_DATA"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
