//! Plugin isolation end to end (issue 12, item 8): `rwg run --isolate` and
//! `isolate = true` run plugin envs in `rwg __plugin-worker` processes.
//! Results are bit-identical to in-process (and to the built-in env the
//! reference plugin mirrors) for any thread count and for shards; a plugin
//! that segfaults, aborts, exits or hangs ends its worker, and rwg itself
//! reports it (exit status 1, never a signal) naming plugin, env, network,
//! episode and step, keeps every committed block and resumes; a plugin's
//! prints never reach rwg's output.

mod common;
use common::*;
use rwg_core::policy::Architecture;
use rwg_core::sampler::{run_blocks, CellPlan, WeightDist};
use rwg_env::ActionDtype;
use rwg_envs::EnvOptions;
use rwg_study::rundir::blocks::{block_samples, finalize_cell, n_blocks, write_block};
use std::path::Path;
use std::process::Output;
use std::time::{Duration, Instant};

fn read(p: impl AsRef<Path>) -> Vec<u8> {
    std::fs::read(p.as_ref()).unwrap_or_else(|e| panic!("{}: {e}", p.as_ref().display()))
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn write(dir: &Path, name: &str, body: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// `rwg run MANIFEST --out DIR --no-report` plus `extra`.
fn run(manifest: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        manifest,
        "--out",
        out.to_str().unwrap(),
        "--no-report",
        "-q",
    ];
    args.extend_from_slice(extra);
    rwg(&args)
}

fn run_ok(manifest: &str, out: &Path, extra: &[&str]) -> String {
    let res = run(manifest, out, extra);
    assert!(
        res.status.success(),
        "rwg run {extra:?} failed: {}",
        text(&res.stderr)
    );
    text(&res.stdout)
}

const SAMPLES: u64 = 70;
const EPISODES: u32 = 2;

/// The reference plugin's twins of built-in envs (MountainCarContinuous in
/// float32 actions).
const TWINS: [(&str, bool); 3] = [
    ("CartPole-v0", false),
    ("Pendulum-v1", false),
    ("MountainCarContinuous-v0", true),
];

/// The cell directories of the twins study.
fn twin_cells() -> Vec<String> {
    let mut v = vec![];
    for (id, _) in TWINS {
        for b in ["nobias", "bias"] {
            v.push(format!("classic_control+{id}__1HL__{b}"));
        }
    }
    v
}

fn twins_manifest(isolate: bool) -> String {
    let mut m = format!(
        "seed = 5\nsamples = {SAMPLES}\nepisodes = {EPISODES}\nbias = [false, true]\n\
         [[architectures]]\nname = \"1HL\"\nhidden = [3]\n"
    );
    for (id, f32_actions) in TWINS {
        m.push_str(&format!(
            "[[envs]]\nid = \"classic_control/{id}\"\nplugin = {:?}\n",
            classic_control_plugin().to_str().unwrap()
        ));
        if f32_actions {
            m.push_str("config = \"action_dtype=float32\"\n");
        }
        if isolate {
            m.push_str("isolate = true\n");
        }
    }
    m
}

/// Computes a cell as `rwg run` does, with the built-in env `builtin`
/// (statically dispatched, in this process) and the seeds of `seed_id`.
fn builtin_cell(dir: &Path, seed_id: &str, builtin: &str, f32_actions: bool, bias: bool) {
    // as the runner does before a cell's first block
    std::fs::create_dir_all(dir).unwrap();
    let plan = CellPlan {
        seed: 5,
        env_id: seed_id.into(),
        arch: Architecture {
            hidden: vec![3],
            bias,
        },
        episodes: EPISODES,
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
    let blocks: Vec<_> = (0..n_blocks(SAMPLES))
        .map(|b| block_samples(b, SAMPLES))
        .collect();
    run_blocks(
        &plan,
        &blocks,
        2,
        || rwg_envs::make(builtin, &opts).unwrap(),
        |b| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
            Ok(write_block(dir, &b, EPISODES)?)
        },
    )
    .unwrap();
    finalize_cell(dir, SAMPLES, EPISODES, u32::MAX, false, &[], |_| None).unwrap();
}

fn assert_same_cells(a: &Path, b: &Path, what: &str) {
    for c in twin_cells() {
        for f in ["scores.csv", "samples.csv"] {
            let p = format!("cells/{c}/{f}");
            assert!(
                read(a.join(&p)) == read(b.join(&p)),
                "{what}: {p} differs between {} and {}",
                a.display(),
                b.display()
            );
        }
    }
}

#[test]
fn isolated_runs_are_bit_identical_to_in_process_and_to_the_builtins() {
    let dir = temp_dir("isolate-same");
    let plain = write(&dir, "plain.toml", &twins_manifest(false));
    let marked = write(&dir, "marked.toml", &twins_manifest(true));
    let inproc = dir.join("inproc");
    run_ok(&plain, &inproc, &["--threads", "2"]);
    for threads in ["1", "2", "3"] {
        let out = dir.join(format!("isolated-{threads}"));
        run_ok(&plain, &out, &["--isolate", "--threads", threads]);
        assert_same_cells(&inproc, &out, &format!("--isolate --threads {threads}"));
    }
    // `isolate = true` in the manifest does the same as --isolate.
    let out = dir.join("marked");
    run_ok(&marked, &out, &["--threads", "2"]);
    assert_same_cells(&inproc, &out, "isolate = true");
    // Not part of the study: the in-process run of the plain manifest finds
    // it complete.
    let again = run_ok(&plain, &out, &[]);
    assert!(
        again.contains("already holds this study, complete"),
        "{again}"
    );

    // Shards: one isolated, one in-process, merged, are the whole run.
    let (s0, s1) = (dir.join("s0"), dir.join("s1"));
    run_ok(&plain, &s0, &["--shard", "0/2", "--isolate"]);
    run_ok(&plain, &s1, &["--shard", "1/2"]);
    let merged = dir.join("merged");
    rwg_ok(&[
        "merge",
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
        "--no-report",
    ]);
    assert_same_cells(&inproc, &merged, "shards, one isolated");

    // The reference plugin's envs are the built-ins': the same cells
    // computed with the built-in envs (and the plugin ids' seeds).
    for (id, f32_actions) in TWINS {
        for bias in [false, true] {
            let b = if bias { "bias" } else { "nobias" };
            let cell = format!("classic_control+{id}__1HL__{b}");
            let reference = dir.join("ref").join(&cell);
            builtin_cell(
                &reference,
                &format!("classic_control/{id}"),
                id,
                f32_actions,
                bias,
            );
            for f in ["scores.csv", "samples.csv"] {
                assert!(
                    read(dir.join("isolated-2/cells").join(&cell).join(f))
                        == read(reference.join(f)),
                    "{cell}/{f}: isolated plugin differs from the built-in"
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A study of one broken env with `samples` networks x 3 episodes.
fn broken_study(dir: &Path, name: &str, env: &str, config: &str, samples: u32) -> String {
    write(
        dir,
        name,
        &format!(
            "samples = {samples}\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"{env}\"\nplugin = {:?}\nconfig = \"{config}\"\n",
            broken_plugin().to_str().unwrap()
        ),
    )
}

/// Runs an isolated study that must fail; checks that rwg itself reported
/// it (exit status 1, not a signal) naming everything; returns stderr.
fn isolated_failure(manifest: &str, out: &Path, extra: &[&str], env: &str) -> String {
    let mut args = vec!["--isolate"];
    args.extend_from_slice(extra);
    let res = run(manifest, out, &args);
    let err = text(&res.stderr);
    assert_eq!(res.status.code(), Some(1), "rwg did not report it:\n{err}");
    let cell = format!("{}__0HL__nobias", env.replace('/', "+"));
    for part in [
        format!("error: cell {cell} (plugin {}", broken_plugin().display()),
        format!("plugin 'broken' env '{env}'"),
        "its isolated worker process".to_string(),
        format!(
            "resume with: rwg run {} --out {} ",
            out.join("manifest.toml").display(),
            out.display()
        ),
    ] {
        assert!(err.contains(&part), "{part:?} missing in:\n{err}");
    }
    assert!(
        text(&res.stdout).is_empty(),
        "stdout: {}",
        text(&res.stdout)
    );
    if let Ok(meta) = std::fs::read_to_string(out.join("run.json")) {
        assert!(meta.contains("\"end_time\": null"), "{meta}");
    }
    err
}

#[test]
fn a_crashing_plugin_ends_its_worker_not_rwg() {
    let dir = temp_dir("isolate-crash");
    let m = broken_study(&dir, "s.toml", "broken/SegfaultInStep-v0", "", 40);
    let err = isolated_failure(&m, &dir.join("s"), &[], "broken/SegfaultInStep-v0");
    assert!(
        err.contains(
            "broken/SegfaultInStep-v0: sample 0, episode 0, step 1: plugin 'broken' env \
             'broken/SegfaultInStep-v0': its isolated worker process was killed by signal 11 \
             (SIGSEGV)"
        ),
        "{err}"
    );

    let m = broken_study(&dir, "a.toml", "broken/AbortInStep-v0", "", 40);
    let err = isolated_failure(
        &m,
        &dir.join("a"),
        &["--threads", "1"],
        "broken/AbortInStep-v0",
    );
    // Step 5 of an instance's 2nd episode (which network's depends on how
    // the batch schedules episodes on its 32 instances).
    assert!(
        err.contains(", step 5: plugin 'broken' env 'broken/AbortInStep-v0': its isolated worker process was killed by signal 6 (SIGABRT)"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn exit_in_a_worker_keeps_committed_blocks_and_resumes_to_identical_results() {
    let dir = temp_dir("isolate-exit");
    // Exits at a worker's 250th reset: blocks 0 and 1 (2 x 32 networks x 3
    // episodes = 192 resets) are committed first with one thread.
    let faulty = broken_study(&dir, "f.toml", "broken/ExitInReset-v0", "at_reset=250", 96);
    let out = dir.join("run");
    let err = isolated_failure(&faulty, &out, &["--threads", "1"], "broken/ExitInReset-v0");
    // Reset 250 is the 58th of block 2 (networks 64..96): network 64 + 57 / 3.
    assert!(
        err.contains(
            "broken/ExitInReset-v0: sample 83, episode 0, step 0: plugin 'broken' env \
             'broken/ExitInReset-v0': its isolated worker process exited with status 0"
        ),
        "{err}"
    );
    let blocks = out.join("cells/broken+ExitInReset-v0__0HL__nobias/blocks");
    for b in ["b0000000.csv", "b0000001.csv"] {
        assert!(
            blocks.join(b).is_file(),
            "{b} was committed before the exit"
        );
    }
    // The rerun (new workers: 96 resets left) finishes the run ...
    run_ok(&faulty, &out, &["--isolate", "--threads", "1"]);
    // ... exactly as an in-process run that never failed.
    let clean = broken_study(
        &dir,
        "c.toml",
        "broken/ExitInReset-v0",
        "at_reset=100000",
        96,
    );
    let out2 = dir.join("clean");
    run_ok(&clean, &out2, &["--threads", "2"]);
    for f in ["scores.csv", "samples.csv"] {
        let p = format!("cells/broken+ExitInReset-v0__0HL__nobias/{f}");
        assert!(read(out.join(&p)) == read(out2.join(&p)), "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_hung_worker_is_killed_after_the_step_timeout() {
    let dir = temp_dir("isolate-hang");
    let m = broken_study(&dir, "h.toml", "broken/HangInStep-v0", "", 40);
    let t0 = Instant::now();
    let err = isolated_failure(
        &m,
        &dir.join("h"),
        &["--step-timeout", "2"],
        "broken/HangInStep-v0",
    );
    assert!(t0.elapsed() < Duration::from_secs(30), "{err}");
    assert!(
        err.contains(
            "broken/HangInStep-v0: sample 0, episode 0, step 1: plugin 'broken' env \
             'broken/HangInStep-v0': its isolated worker process did not answer within 2 s"
        ),
        "{err}"
    );
    assert!(err.contains("raise --step-timeout"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plugin_prints_never_reach_rwg_output_or_the_protocol() {
    let dir = temp_dir("isolate-print");
    // A Rust plugin's println! on every reset.
    let m = broken_study(&dir, "p.toml", "broken/PrintInReset-v0", "", 40);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let res = run(&m, &a, &["--isolate"]);
    assert!(res.status.success(), "{}", text(&res.stderr));
    for stream in [&res.stdout, &res.stderr] {
        assert!(!text(stream).contains("says hello"), "{}", text(stream));
    }
    assert!(text(&res.stdout).contains("broken+PrintInReset-v0__0HL__nobias"));
    run_ok(&m, &b, &[]);
    let p = "cells/broken+PrintInReset-v0__0HL__nobias/scores.csv";
    assert!(read(a.join(p)) == read(b.join(p)));

    // A C plugin's printf in every step (buffered by libc: written in
    // chunks at any time, and at exit).
    let lib = compile_c(
        "isolate-printf",
        "plugins/testing/c/handshake.c",
        "talks",
        &["PRINTF_IN_STEP"],
    );
    let m = write(
        &dir,
        "c.toml",
        &format!(
            "samples = 40\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
             [[envs]]\nid = \"handshake/Ok-v0\"\nplugin = {:?}\n",
            lib.to_str().unwrap()
        ),
    );
    let (c, d) = (dir.join("c"), dir.join("d"));
    let res = run(&m, &c, &["--isolate", "--threads", "2"]);
    assert!(res.status.success(), "{}", text(&res.stderr));
    assert!(
        !text(&res.stdout).contains("handshake plugin"),
        "{}",
        text(&res.stdout)
    );
    run_ok(&m, &d, &[]);
    let p = "cells/handshake+Ok-v0__0HL__nobias/scores.csv";
    assert!(read(c.join(p)) == read(d.join(p)));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_isolate_key_is_validated_and_a_no_op_for_builtins() {
    let dir = temp_dir("isolate-key");
    let head = "samples = 3\nepisodes = 1\n[[architectures]]\nname = \"0HL\"\nhidden = []\n";
    let m = write(
        &dir,
        "bad.toml",
        &format!("{head}[[envs]]\nid = \"CartPole-v1\"\nisolate = \"yes\"\n"),
    );
    let err = rwg_err(&["run", &m, "--out", dir.join("x").to_str().unwrap()]);
    assert!(
        err.contains("bad.toml:8:11: envs[0].isolate: expected true or false"),
        "{err}"
    );
    // Built-in envs are rwg's own code: isolate changes nothing for them.
    let m = write(
        &dir,
        "builtin.toml",
        &format!("{head}[[envs]]\nid = \"CartPole-v1\"\nisolate = true\n"),
    );
    let plain = write(
        &dir,
        "plain.toml",
        &format!("{head}[[envs]]\nid = \"CartPole-v1\"\n"),
    );
    let (a, b) = (dir.join("a"), dir.join("b"));
    run_ok(&m, &a, &[]);
    run_ok(&plain, &b, &["--isolate"]);
    let p = "cells/CartPole-v1__0HL__nobias/scores.csv";
    assert!(read(a.join(p)) == read(b.join(p)));
    // `rwg slurm --isolate` writes it into the shards' manifest.
    let plugin = write(
        &dir,
        "plugin.toml",
        &format!(
            "{head}[[envs]]\nid = \"classic_control/CartPole-v1\"\nplugin = {:?}\n",
            classic_control_plugin().to_str().unwrap()
        ),
    );
    let study = dir.join("study");
    rwg_ok(&[
        "slurm",
        &plugin,
        "--shards",
        "2",
        "--out",
        study.to_str().unwrap(),
        "--isolate",
        "--dry-run",
    ]);
    let shards_manifest = text(&read(study.join("slurm/manifest.toml")));
    assert!(
        shards_manifest.contains("isolate = true"),
        "{shards_manifest}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C on a terminal signals the whole process group, workers included:
/// rwg stops after the blocks in flight, as in-process, and the workers do
/// not turn it into a crash report.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_an_isolated_run_like_an_in_process_one() {
    let dir = temp_dir("isolate-ctrlc");
    let m = write(
        &dir,
        "m.toml",
        &format!(
            "samples = 100000\nepisodes = 20\n[[architectures]]\nname = \"1HL\"\nhidden = [4]\n\
             [[envs]]\nid = \"classic_control/CartPole-v1\"\nplugin = {:?}\n",
            classic_control_plugin().to_str().unwrap()
        ),
    );
    let out = dir.join("run");
    let mut cmd = std::process::Command::new(rwg_bin());
    cmd.args(["run", &m, "--out", out.to_str().unwrap(), "--isolate", "-q"])
        .args(["--threads", "2", "--no-report"]);
    // Once the workers run (their first block committed).
    let blocks = out.join("cells/classic_control+CartPole-v1__1HL__nobias/blocks");
    let err = ctrl_c_after_first_block(cmd, &blocks);
    assert!(!err.contains("worker process"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
