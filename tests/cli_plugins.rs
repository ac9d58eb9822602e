//! Plugin environments end to end: `rwg run` with `plugin =` and
//! `RWG_PLUGIN_PATH`, failures inside a plugin during a run, manifest errors
//! about plugins, and `rwg envs` with plugins.
//!
//! The plugin libraries are built by cargo (the plugin packages are
//! dev-dependencies of rwg-cli) or compiled here from C.

mod common;
use common::*;
use rwg_core::policy::Architecture;
use rwg_core::sampler::{run_blocks, CellPlan, WeightDist};
use rwg_env::ActionDtype;
use rwg_envs::EnvOptions;
use rwg_study::rundir::blocks::{block_samples, finalize_cell, n_blocks, write_block};
use std::ffi::OsStr;
use std::path::Path;

fn read(p: impl AsRef<Path>) -> String {
    std::fs::read_to_string(p.as_ref()).unwrap_or_else(|e| panic!("{}: {e}", p.as_ref().display()))
}

fn write_manifest(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

fn toml_str(p: &Path) -> String {
    format!("{:?}", p.to_str().unwrap())
}

const HEAD: &str = "seed = 7\nsamples = 33\nepisodes = 2\nbias = [false, true]\n\
                    [[architectures]]\nname = \"1HL\"\nhidden = [3]\n";

/// The built-in envs the equivalence test covers, with the config / action
/// dtype they run with (MountainCarContinuous in float32 arithmetic).
const TWINS: [(&str, bool); 4] = [
    ("CartPole-v0", false),
    ("Acrobot-v1", false),
    ("Pendulum-v1", false),
    ("MountainCarContinuous-v0", true),
];

/// Computes a cell the way `rwg run` does, with the built-in env `builtin`
/// (statically dispatched, no plugin involved) but the seeds of `seed_id`,
/// and writes scores.csv / samples.csv into `dir`.
fn builtin_cell(dir: &Path, seed_id: &str, builtin: &str, f32_actions: bool, bias: bool) {
    // as the runner does before a cell's first block
    std::fs::create_dir_all(dir).unwrap();
    let plan = CellPlan {
        seed: 7,
        env_id: seed_id.into(),
        arch: Architecture {
            hidden: vec![3],
            bias,
        },
        episodes: 2,
        dist: WeightDist::Normal { std: 1.0 },
        policy: rwg_core::policy::PolicyKind::Network,
        non_finite: Default::default(),
    };
    let opts = EnvOptions {
        action_dtype: if f32_actions {
            ActionDtype::F32
        } else {
            ActionDtype::F64
        },
        max_episode_steps: None,
    };
    let blocks: Vec<_> = (0..n_blocks(33)).map(|b| block_samples(b, 33)).collect();
    run_blocks(
        &plan,
        &blocks,
        2,
        || rwg_envs::make(builtin, &opts).unwrap(),
        |b| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
            Ok(write_block(dir, &b, 2)?)
        },
    )
    .unwrap();
    finalize_cell(dir, 33, 2, u32::MAX, false, &[], |_| None).unwrap();
}

/// Seeds derive from the env id, and a plugin id never equals a built-in id,
/// so `classic_control/CartPole-v0` and `CartPole-v0` get different networks
/// and initial states. The honest comparison: the plugin run against the
/// built-in env computed with the same seeds (the plugin id's), and the
/// built-in run against the same computation with the built-in id's seeds.
/// Both must be byte-identical.
#[test]
fn reference_plugin_reproduces_the_builtin_envs_byte_for_byte() {
    let dir = temp_dir("plugin-twins");
    let lib = classic_control_plugin();
    let mut with_plugin = HEAD.to_string();
    let mut builtin = HEAD.to_string();
    for (id, f32_actions) in TWINS {
        with_plugin.push_str(&format!(
            "[[envs]]\nid = \"classic_control/{id}\"\nplugin = {}\n",
            toml_str(&lib)
        ));
        builtin.push_str(&format!("[[envs]]\nid = \"{id}\"\n"));
        if f32_actions {
            with_plugin.push_str("config = \"action_dtype=float32\"\n");
            builtin.push_str("action_dtype = \"float32\"\n");
        }
    }
    let mp = write_manifest(&dir, "plugin.toml", &with_plugin);
    let mb = write_manifest(&dir, "builtin.toml", &builtin);
    let (rp, rb) = (dir.join("run-plugin"), dir.join("run-builtin"));
    rwg_ok(&["run", &mp, "--out", rp.to_str().unwrap()]);
    rwg_ok(&["run", &mb, "--out", rb.to_str().unwrap()]);

    for (id, f32_actions) in TWINS {
        for bias in [false, true] {
            let b = if bias { "bias" } else { "nobias" };
            let plugin_cell = format!("classic_control+{id}__1HL__{b}");
            let builtin_cell_dir = format!("{id}__1HL__{b}");
            let ref_plugin = dir.join("ref-plugin-seeds").join(&plugin_cell);
            let ref_builtin = dir.join("ref-builtin-seeds").join(&builtin_cell_dir);
            builtin_cell(
                &ref_plugin,
                &format!("classic_control/{id}"),
                id,
                f32_actions,
                bias,
            );
            builtin_cell(&ref_builtin, id, id, f32_actions, bias);
            for f in ["scores.csv", "samples.csv"] {
                let got = read(rp.join("cells").join(&plugin_cell).join(f));
                assert_eq!(
                    got,
                    read(ref_plugin.join(f)),
                    "{plugin_cell}/{f}: the plugin differs from the built-in"
                );
                assert_eq!(
                    got.lines().count(),
                    1 + if f == "scores.csv" { 66 } else { 33 }
                );
                assert_eq!(
                    read(rb.join("cells").join(&builtin_cell_dir).join(f)),
                    read(ref_builtin.join(f)),
                    "{builtin_cell_dir}/{f}"
                );
            }
        }
    }
    // Different ids, different seeds: the two runs are different samples.
    assert_ne!(
        read(rp.join("cells/classic_control+CartPole-v0__1HL__nobias/scores.csv")),
        read(rb.join("cells/CartPole-v0__1HL__nobias/scores.csv"))
    );
}

#[test]
fn a_failing_plugin_stops_its_cell_names_everything_and_keeps_earlier_cells() {
    let dir = temp_dir("plugin-failures");
    let broken = broken_plugin();
    let classic = classic_control_plugin();
    let cases = [
        (
            "broken/PanicInStep-v0",
            3,
            "step failed with RWG_ERR_PANIC (5): panic: broken/PanicInStep-v0 panics on step 3",
        ),
        (
            "broken/NaNObservation-v0",
            2,
            "step returned a non-finite observation: obs[0] = NaN",
        ),
        (
            "broken/NaNReward-v0",
            2,
            "step returned a non-finite reward: NaN",
        ),
    ];
    for (id, step, what) in cases {
        let m = write_manifest(
            &dir,
            "m.toml",
            &format!(
                "seed = 3\nsamples = 40\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                 [[envs]]\nid = \"CartPole-v0\"\n\
                 [[envs]]\nid = \"classic_control/CartPole-v0\"\nplugin = {}\n\
                 [[envs]]\nid = \"{id}\"\nplugin = {}\n",
                toml_str(&classic),
                toml_str(&broken)
            ),
        );
        let out = dir.join(id.replace('/', "_"));
        let res = rwg_env(&["run", &m, "--out", out.to_str().unwrap()], &[]);
        let stderr = String::from_utf8_lossy(&res.stderr);
        assert_eq!(res.status.code(), Some(1), "{id}: {stderr}");
        let cell = format!("broken+{}__0HL__nobias", id.split('/').nth(1).unwrap());
        for needle in [
            format!("cell {cell} (plugin {}) failed", broken.display()),
            format!("{id}: sample 0, episode 0, step {step}: plugin 'broken' env '{id}': {what}"),
            format!("saved in {}", out.display()),
        ] {
            assert!(
                stderr.contains(&needle),
                "{id}: no {needle:?} in:\n{stderr}"
            );
        }
        // rwg's message comes once, not repeated by the error chain (the
        // plugin's own panic hook may print the panic before it, on its
        // own lines: that is the plugin's output, not rwg's).
        let error = &stderr[stderr.find("error: ").expect("an error line")..];
        assert_eq!(error.matches(what).count(), 1, "{stderr}");
        // The cells before are complete.
        for done in [
            "CartPole-v0__0HL__nobias",
            "classic_control+CartPole-v0__0HL__nobias",
        ] {
            let c = out.join("cells").join(done);
            assert_eq!(read(c.join("scores.csv")).lines().count(), 1 + 40 * 3);
            assert_eq!(read(c.join("samples.csv")).lines().count(), 1 + 40);
            assert!(c.join("cell.json").is_file());
        }
        assert!(!out.join("cells").join(&cell).join("scores.csv").exists());
        let meta: serde_json::Value = serde_json::from_str(&read(out.join("run.json"))).unwrap();
        assert_eq!(meta["cells"].as_array().unwrap().len(), 2);
        assert!(meta["end_time"].is_null());
    }
}

#[test]
fn plugin_problems_are_manifest_errors_with_a_location() {
    let dir = temp_dir("plugin-manifest-errors");
    let classic = classic_control_plugin();
    let no_entry = compile_c(
        "manifest-errors",
        "plugins/testing/c/handshake.c",
        "no_entry",
        &["BROKEN_NO_ENTRY"],
    );
    let wrong_major = compile_c(
        "manifest-errors",
        "plugins/testing/c/handshake.c",
        "wrong_major",
        &["BROKEN_WRONG_MAJOR"],
    );
    // Line 10 holds the id (column 6), line 11 the plugin or config (column
    // 10), line 12 the config after a plugin.
    let head =
        "seed = 0\nsamples = 2\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
                [[envs]]\nid = \"CartPole-v0\"\n";
    let cases: Vec<(String, String)> = vec![
        (
            "id = \"acme/Maze-v0\"\nplugin = \"libs/libmissing.so\"".into(),
            format!(
                "m.toml:11:10: envs[1].plugin: no such file: {}",
                dir.join("libs/libmissing.so").display()
            ),
        ),
        (
            format!("id = \"handshake/Ok-v0\"\nplugin = {}", toml_str(&no_entry)),
            format!(
                "m.toml:11:10: envs[1].plugin: plugin {}: not an rwg plugin",
                no_entry.display()
            ),
        ),
        (
            format!("id = \"handshake/Ok-v0\"\nplugin = {}", toml_str(&wrong_major)),
            "m.toml:11:10: envs[1].plugin: plugin ".to_string()
                + &format!("{}: ABI version mismatch: the plugin was built for ABI 2.2", wrong_major.display()),
        ),
        (
            format!("id = \"classic_control/CartPol-v0\"\nplugin = {}", toml_str(&classic)),
            format!(
                "m.toml:10:6: envs[1].id: plugin 'classic_control' ({}) has no environment \
                 'classic_control/CartPol-v0' (did you mean 'classic_control/CartPole-v0'?); \
                 its environments: classic_control/CartPole-v0, classic_control/CartPole-v1, \
                 classic_control/Acrobot-v1,",
                classic.display()
            ),
        ),
        (
            format!("id = \"CartPole-v1\"\nplugin = {}", toml_str(&classic)),
            "m.toml:10:6: envs[1].id: 'CartPole-v1' is a built-in environment; remove `plugin`".into(),
        ),
        (
            format!("id = \"classic_control/CartPole-v1\"\nplugin = {}\nconfig = \"speed=2\"", toml_str(&classic)),
            "m.toml:12:10: envs[1]: cannot create 'classic_control/CartPole-v1' with config \"speed=2\": \
             plugin 'classic_control' env 'classic_control/CartPole-v1': create failed with \
             RWG_ERR_INVALID_ARGUMENT (1): unknown config item 'speed=2'"
                .into(),
        ),
        (
            "id = \"CartPole-v1\"\nconfig = \"x=1\"".into(),
            "m.toml:11:10: envs[1].config: 'CartPole-v1' is built in; only plugin environments take a config string".into(),
        ),
        (
            format!("id = \"classic_control/Pendulum-v1\"\nplugin = {}\naction_dtype = \"float32\"", toml_str(&classic)),
            "m.toml:10:6: envs[1].action_dtype: applies to built-in environments only".into(),
        ),
        (
            "id = \"acme/Maze-v0\"".into(),
            "m.toml:10:6: envs: unknown environment 'acme/Maze-v0'; known environments: CartPole-v0,"
                .into(),
        ),
    ];
    for (entry, expected) in cases {
        let m = write_manifest(&dir, "m.toml", &format!("{head}[[envs]]\n{entry}\n"));
        let out = dir.join("never");
        let res = rwg_env(&["run", &m, "--out", out.to_str().unwrap()], &[]);
        let err = String::from_utf8_lossy(&res.stderr);
        assert!(!res.status.success());
        assert!(err.contains(&expected), "expected {expected:?} in:\n{err}");
        assert!(!out.exists(), "{entry}: the run must not start");
    }
}

#[test]
fn rwg_plugin_path_provides_envs_to_run_and_to_list() {
    let dir = temp_dir("plugin-path");
    let pp = dir.join("plugins");
    std::fs::create_dir_all(&pp).unwrap();
    let so = rwg_plugin_host::library_file_name;
    let example = pp.join(so("rwg_example_plugin"));
    std::fs::copy(rust_plugin("rwg_example_plugin"), &example).unwrap();
    std::fs::write(pp.join(so("junk")), "not a library").unwrap();
    // A plugin exporting a built-in id is rejected: it never shadows the built-in.
    let shadow = compile_c(
        "plugin-path",
        "plugins/testing/c/handshake.c",
        "shadow",
        &["ENV_ID=\"CartPole-v0\""],
    );
    std::fs::copy(&shadow, pp.join(so("shadow"))).unwrap();
    let path_var = [("RWG_PLUGIN_PATH", pp.as_os_str())];

    let res = rwg_env(&["envs"], &path_var);
    assert!(res.status.success());
    let (stdout, stderr) = (
        String::from_utf8_lossy(&res.stdout),
        String::from_utf8_lossy(&res.stderr),
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("example/PointMass-v0 "))
        .unwrap_or_else(|| panic!("no example env in:\n{stdout}"));
    assert!(line.ends_with(example.to_str().unwrap()), "{line}");
    let cartpole = stdout
        .lines()
        .find(|l| l.starts_with("CartPole-v0 "))
        .unwrap();
    assert!(cartpole.ends_with("(built in)"), "{cartpole}");
    assert!(stderr.contains("rejected on RWG_PLUGIN_PATH:"), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}: environment id 'CartPole-v0' is built into rwg",
            pp.join(so("shadow")).display()
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!(
            "{}: cannot open the library",
            pp.join(so("junk")).display()
        )),
        "{stderr}"
    );

    let res = rwg_env(&["envs", "--json"], &path_var);
    let rows: serde_json::Value = serde_json::from_slice(&res.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    let find = |id: &str| rows.iter().find(|r| r["id"] == id).unwrap();
    assert_eq!(
        find("example/PointMass-v0")["plugin"],
        example.to_str().unwrap()
    );
    assert_eq!(find("example/PointMass-v0")["max_episode_steps"], 200);
    assert!(find("CartPole-v0")["plugin"].is_null());

    // An id neither built in nor given a plugin comes from RWG_PLUGIN_PATH;
    // the run's manifest names the file, so it re-runs without the variable.
    let m = write_manifest(
        &dir,
        "m.toml",
        "samples = 40\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"CartPole-v0\"\n[[envs]]\nid = \"example/PointMass-v0\"\n",
    );
    let out = dir.join("run");
    let res = rwg_env(&["run", &m, "--out", out.to_str().unwrap()], &path_var);
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let resolved = read(out.join("manifest.toml"));
    assert!(
        resolved.contains(&format!("plugin = {}", toml_str(&example))),
        "{resolved}"
    );
    let res = rwg_env(&["run", &m, "--out", out.to_str().unwrap()], &path_var);
    assert!(String::from_utf8_lossy(&res.stdout).contains("nothing to do"));
    let again = dir.join("again");
    let res = rwg_env(
        &[
            "run",
            out.join("manifest.toml").to_str().unwrap(),
            "--out",
            again.to_str().unwrap(),
        ],
        &[],
    );
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let cell = "cells/example+PointMass-v0__0HL__nobias/scores.csv";
    assert_eq!(read(out.join(cell)), read(again.join(cell)));
    // Replay regenerates a plugin env's episodes from the run's manifest.
    let res = rwg_env(
        &[
            "replay",
            out.to_str().unwrap(),
            "--env",
            "example/PointMass-v0",
            "--arch",
            "0HL",
            "--sample",
            "3",
        ],
        &[],
    );
    let replay = String::from_utf8_lossy(&res.stdout);
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    assert_eq!(
        replay.lines().filter(|l| l.ends_with(",true")).count(),
        2,
        "{replay}"
    );

    // Without the variable the id is unknown, and the message says where to look.
    let res = rwg_env(&["run", &m, "--out", dir.join("no").to_str().unwrap()], &[]);
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(
        err.contains("unknown environment 'example/PointMass-v0'")
            && err.contains("or list its folder in RWG_PLUGIN_PATH"),
        "{err}"
    );
    let res = rwg_env(
        &["run", &m, "--out", dir.join("no").to_str().unwrap()],
        &[("RWG_PLUGIN_PATH", OsStr::new("/nonexistent-rwg-plugins"))],
    );
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(
        err.contains("no plugin environments on RWG_PLUGIN_PATH")
            && err.contains("/nonexistent-rwg-plugins: cannot read the plugin directory"),
        "{err}"
    );
}

#[test]
fn envs_plugin_lists_one_plugins_envs_with_the_file() {
    let lib = classic_control_plugin();
    let out = rwg_ok(&["envs", "--plugin", lib.to_str().unwrap()]);
    let lines: Vec<&str> = out.lines().collect();
    assert!(
        lines[0].starts_with("id ") && lines[0].ends_with(" plugin"),
        "{out}"
    );
    assert_eq!(lines.len(), 1 + 7, "{out}");
    let cartpole = lines
        .iter()
        .find(|l| l.starts_with("classic_control/CartPole-v0 "))
        .unwrap();
    assert!(
        cartpole.contains("Discrete(2)")
            && cartpole.contains(" 200 ")
            && cartpole.contains("195")
            && cartpole.ends_with(lib.to_str().unwrap()),
        "{cartpole}"
    );
    let json = rwg_ok(&["envs", "--plugin", lib.to_str().unwrap(), "--json"]);
    let rows: serde_json::Value = serde_json::from_str(&json).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 7);
    for r in rows {
        assert_eq!(r["plugin"], lib.to_str().unwrap());
        assert!(r["id"].as_str().unwrap().starts_with("classic_control/"));
    }
    let acro = rows
        .iter()
        .find(|r| r["id"] == "classic_control/Acrobot-v1")
        .unwrap();
    assert_eq!(acro["reward_threshold"], -100.0);
    assert!(acro["summary"].as_str().unwrap().contains("Acrobot"));

    let err = rwg_err(&["envs", "--plugin", "/nonexistent/libnothing.so"]);
    assert!(
        err.contains("plugin /nonexistent/libnothing.so: cannot open the library"),
        "{err}"
    );
}

#[test]
fn rollout_looks_inside_a_plugin_env() {
    let plugin = classic_control_plugin();
    let p = plugin.to_str().unwrap();
    // the reference plugin's CartPole starts and steps exactly as the built-in
    let ours = rwg_ok(&[
        "rollout",
        "classic_control/CartPole-v0",
        "--plugin",
        p,
        "--seed",
        "3",
        "--actions",
        "0,1,1",
    ]);
    let builtin = rwg_ok(&[
        "rollout",
        "CartPole-v0",
        "--seed",
        "3",
        "--actions",
        "0,1,1",
    ]);
    assert_eq!(ours, builtin);
    // found on RWG_PLUGIN_PATH too
    let dir = plugin.parent().unwrap().as_os_str();
    let out = rwg_env(
        &[
            "rollout",
            "classic_control/CartPole-v0",
            "--seed",
            "3",
            "--actions",
            "0,1,1",
        ],
        &[("RWG_PLUGIN_PATH", dir)],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8(out.stdout).unwrap(), builtin);
    // errors: an id the plugin lacks, and --state (not in ABI v1)
    let err = rwg_err(&["rollout", "classic_control/Nope-v0", "--plugin", p]);
    assert!(
        err.contains("has no environment 'classic_control/Nope-v0'")
            && err.contains("classic_control/Acrobot-v1"),
        "{err}"
    );
    let err = rwg_err(&[
        "rollout",
        "classic_control/CartPole-v0",
        "--plugin",
        p,
        "--state",
        "0,0,0,0",
    ]);
    assert!(err.contains("does not expose its internal state"), "{err}");
}

#[test]
fn bench_compares_a_plugin_env_with_the_builtin_it_reexports() {
    let plugin = classic_control_plugin();
    let out = rwg_ok(&[
        "bench",
        "envs",
        "--plugin",
        plugin.to_str().unwrap(),
        "--env",
        "classic_control/CartPole-v0",
        "--steps",
        "2000",
        "--json",
    ]);
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["env"], "classic_control/CartPole-v0");
    assert_eq!(rows[0]["vs_builtin"]["builtin"], "CartPole-v0");
    assert!(rows[0]["vs_builtin"]["ratio"].as_f64().unwrap() > 0.0);
    // the same steps and actions: the plugin's rewards are the built-in's
    let builtin = rwg_ok(&[
        "bench",
        "envs",
        "--env",
        "CartPole-v0",
        "--steps",
        "2000",
        "--json",
    ]);
    let b: serde_json::Value = serde_json::from_str(&builtin).unwrap();
    assert_eq!(rows[0]["reward_sum"], b[0]["reward_sum"]);
    assert_eq!(rows[0]["episodes"], b[0]["episodes"]);
}
