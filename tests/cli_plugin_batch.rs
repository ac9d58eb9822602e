//! ABI 1.1's batched calls in `rwg run` and `rwg check` (issue 13): a study
//! on a plugin gives the same `scores.csv` and `samples.csv` bytes through
//! the batched calls and the single ones (`RWG_PLUGIN_BATCH=0`), a plugin
//! built against the 1.0 header loads and runs with the same results, `rwg
//! check` compares the two paths, and a crash inside a batched call (the
//! default path) is reported as one.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A manifest of `envs` (id, plugin file, config) with two architectures.
fn manifest(dir: &Path, envs: &[(&str, &Path, &str)], samples: u32) -> String {
    let mut body = format!(
        "seed = 7\nsamples = {samples}\nepisodes = 2\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[architectures]]\nname = \"2HL-4-4\"\nhidden = [4, 4]\n"
    );
    for (id, plugin, config) in envs {
        body.push_str(&format!(
            "[[envs]]\nid = \"{id}\"\nplugin = \"{}\"\nconfig = \"{config}\"\n",
            plugin.display()
        ));
    }
    let p = dir.join("m.toml");
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// Runs the study into `out` with `RWG_PLUGIN_BATCH` set to `batch`.
fn run(manifest: &str, out: &Path, batch: &str) {
    let res = rwg_env(
        &[
            "run",
            manifest,
            "--out",
            out.to_str().unwrap(),
            "--no-report",
            "--threads",
            "2",
        ],
        &[("RWG_PLUGIN_BATCH", batch.as_ref())],
    );
    assert!(res.status.success(), "{}", text(&res.stderr));
}

/// Every cell's scores.csv and samples.csv, by cell directory name.
fn results(out: &Path) -> Vec<(String, Vec<u8>, Vec<u8>)> {
    let mut cells: Vec<PathBuf> = std::fs::read_dir(out.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cells.sort();
    assert!(!cells.is_empty());
    cells
        .iter()
        .map(|c| {
            (
                c.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(c.join("scores.csv")).unwrap(),
                std::fs::read(c.join("samples.csv")).unwrap(),
            )
        })
        .collect()
}

#[test]
fn reference_plugin_studies_are_identical_with_and_without_batching() {
    let dir = temp_dir("batch-classic");
    let lib = classic_control_plugin();
    let envs: Vec<(String, &str)> = [
        ("CartPole-v0", ""),
        ("CartPole-v1", ""),
        ("Acrobot-v1", ""),
        ("MountainCar-v0", ""),
        ("MountainCarContinuous-v0", "action_dtype=float32"),
        ("Pendulum-v0", ""),
        ("Pendulum-v1", "action_dtype=float32"),
    ]
    .into_iter()
    .map(|(id, c)| (format!("classic_control/{id}"), c))
    .collect();
    let entries: Vec<(&str, &Path, &str)> = envs
        .iter()
        .map(|(id, c)| (id.as_str(), lib.as_path(), *c))
        .collect();
    // 100 networks: 4 blocks of 32 on 2 threads, so a thread's batch of
    // instances is used again for a later block.
    let m = manifest(&dir, &entries, 100);
    run(&m, &dir.join("batched"), "1");
    run(&m, &dir.join("single"), "0");
    let (a, b) = (results(&dir.join("batched")), results(&dir.join("single")));
    assert_eq!(a.len(), 14);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(x.1 == y.1, "{}: scores.csv differs", x.0);
        assert!(x.2 == y.2, "{}: samples.csv differs", x.0);
    }
}

#[test]
fn a_plugin_built_against_the_1_0_header_runs_with_the_same_results() {
    let dir = temp_dir("batch-v1_0");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let new = compile_c("batch-v1_1", "examples/plugin-c/chain.c", "chain", &[]);
    // The same source against the header as it was at ABI 1.0.
    let old_dir = dir.join("v1_0");
    std::fs::create_dir_all(&old_dir).unwrap();
    let old = old_dir.join(rwg_plugin_host::library_file_name("chain"));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let res = Command::new(&cc)
        .args([
            "-std=c11",
            "-O1",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
        ])
        .args(["-shared", "-fPIC", "-fvisibility=hidden", "-I"])
        .arg(root.join("tests/data/abi-v1.0"))
        .arg(root.join("examples/plugin-c/chain.c"))
        .arg("-o")
        .arg(&old)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler '{cc}': {e}"));
    assert!(res.status.success(), "{}", text(&res.stderr));

    let envs = rwg_ok(&["envs", "--plugin", old.to_str().unwrap()]);
    assert!(envs.contains("c_example/Chain-v0"), "{envs}");
    let id = "c_example/Chain-v0";
    let m_old = manifest(&old_dir, &[(id, &old, "length=6")], 64);
    let new_dir = dir.join("v1_1");
    std::fs::create_dir_all(&new_dir).unwrap();
    let m_new = manifest(&new_dir, &[(id, &new, "length=6")], 64);
    run(&m_old, &dir.join("old"), "1");
    run(&m_new, &dir.join("batched"), "1");
    run(&m_new, &dir.join("single"), "0");
    let old_r = results(&dir.join("old"));
    assert_eq!(old_r, results(&dir.join("batched")));
    assert_eq!(old_r, results(&dir.join("single")));

    // rwg check: 1.0 has no batched calls; 1.1's agree with its single calls.
    let out = rwg(&["check", old.to_str().unwrap()]);
    let t = text(&out.stdout);
    assert!(out.status.success(), "{t}{}", text(&out.stderr));
    assert!(
        t.contains("batched calls: no batched calls (an ABI 1.0 plugin"),
        "{t}"
    );
    let out = rwg(&["check", new.to_str().unwrap()]);
    let t = text(&out.stdout);
    assert!(out.status.success(), "{t}{}", text(&out.stderr));
    assert!(
        t.contains("batched calls: reset_many/step_many equal the single calls bit for bit"),
        "{t}"
    );
}

#[cfg(unix)]
#[test]
fn a_crash_in_a_batched_step_is_reported_as_one() {
    use std::os::unix::process::ExitStatusExt;
    let dir = temp_dir("batch-segv");
    let m = manifest(
        &dir,
        &[("broken/SegfaultInStep-v0", &broken_plugin(), "")],
        40,
    );
    // Without RWG_PLUGIN_BATCH: the batched calls are the default.
    let res = Command::new(rwg_bin())
        .args([
            "run",
            &m,
            "--out",
            dir.join("s").to_str().unwrap(),
            "--no-report",
        ])
        .env_remove("RWG_PLUGIN_PATH")
        .env_remove("RWG_PLUGIN_BATCH")
        .output()
        .unwrap();
    let err = text(&res.stderr);
    assert_eq!(res.status.signal(), Some(11), "{err}");
    assert!(
        err.contains("killed by SIGSEGV (invalid memory access) in step_many (a batched step): "),
        "{err}"
    );
    assert!(err.contains("env 'broken/SegfaultInStep-v0'"), "{err}");
    assert!(
        err.contains(
            "one of 16 lanes (batched call 2 of the thread; rerun with RWG_PLUGIN_BATCH=0"
        ),
        "{err}"
    );
}
