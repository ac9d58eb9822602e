//! ABI 1.1's batched calls and 1.2's vector env in `rwg run` and `rwg
//! check` (issue 13): a study on a plugin gives the same `scores.csv` and
//! `samples.csv` bytes through the vector env (the default), the batched
//! calls (`RWG_PLUGIN_VEC=0`) and the single calls (`RWG_PLUGIN_BATCH=0`),
//! plugins built against the 1.0 and 1.1 headers load and run with the same
//! results, `rwg check` compares the paths, and a crash inside a batched
//! call or a vector env's call is reported as one.

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

/// The three paths of a plugin env: the vector env (the default), the
/// batched calls and the single calls, by the variables that choose them.
const PATHS: [(&str, &[(&str, &str)]); 3] = [
    ("vec", &[("RWG_PLUGIN_BATCH", "1"), ("RWG_PLUGIN_VEC", "1")]),
    (
        "batched",
        &[("RWG_PLUGIN_BATCH", "1"), ("RWG_PLUGIN_VEC", "0")],
    ),
    (
        "single",
        &[("RWG_PLUGIN_BATCH", "0"), ("RWG_PLUGIN_VEC", "1")],
    ),
];

/// Runs the study into `out` with the environment variables `vars`.
fn run(manifest: &str, out: &Path, vars: &[(&str, &str)]) {
    let vars: Vec<(&str, &std::ffi::OsStr)> = vars.iter().map(|(k, v)| (*k, v.as_ref())).collect();
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
        &vars,
    );
    assert!(res.status.success(), "{}", text(&res.stderr));
}

/// Runs the study once per path into `dir/<path>`; the results of each.
fn run_paths(manifest: &str, dir: &Path) -> Vec<Vec<CellFiles>> {
    PATHS
        .iter()
        .map(|(name, vars)| {
            run(manifest, &dir.join(name), vars);
            results(&dir.join(name))
        })
        .collect()
}

/// A cell's directory name, `scores.csv` and `samples.csv`.
type CellFiles = (String, Vec<u8>, Vec<u8>);

/// Every cell's scores.csv and samples.csv, by cell directory name.
fn results(out: &Path) -> Vec<CellFiles> {
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
fn reference_plugin_studies_are_identical_through_all_three_paths() {
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
    let r = run_paths(&m, &dir);
    assert_eq!(r[0].len(), 14);
    for other in &r[1..] {
        for (x, y) in r[0].iter().zip(other) {
            assert_eq!(x.0, y.0);
            assert!(x.1 == y.1, "{}: scores.csv differs", x.0);
            assert!(x.2 == y.2, "{}: samples.csv differs", x.0);
        }
    }
}

/// Compiles `examples/plugin-c/chain.c` against the header in `include`
/// (relative to the repository) into `dir`.
fn chain_against(include: &str, dir: &Path) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    std::fs::create_dir_all(dir).unwrap();
    let lib = dir.join(rwg_plugin_host::library_file_name("chain"));
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
        .arg(root.join(include))
        .arg(root.join("examples/plugin-c/chain.c"))
        .arg("-o")
        .arg(&lib)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler '{cc}': {e}"));
    assert!(res.status.success(), "{}", text(&res.stderr));
    lib
}

/// `rwg check`'s output on `lib`, which must pass.
fn check_text(lib: &Path) -> String {
    let out = rwg(&["check", lib.to_str().unwrap()]);
    let t = text(&out.stdout);
    assert!(out.status.success(), "{t}{}", text(&out.stderr));
    t
}

#[test]
fn plugins_built_against_the_1_0_and_1_1_headers_run_with_the_same_results() {
    let dir = temp_dir("batch-v1_0");
    let new = compile_c("batch-v1_2", "examples/plugin-c/chain.c", "chain", &[]);
    // The same source against the header as it was at ABI 1.0 and 1.1.
    let v10 = chain_against("tests/data/abi-v1.0", &dir.join("v1_0"));
    let v11 = chain_against("tests/data/abi-v1.1", &dir.join("v1_1"));
    let envs = rwg_ok(&["envs", "--plugin", v10.to_str().unwrap()]);
    assert!(envs.contains("c_example/Chain-v0"), "{envs}");
    let id = "c_example/Chain-v0";
    let study = |lib: &Path, name: &str| {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        manifest(&d, &[(id, lib, "length=6")], 64)
    };
    // 1.0 has the single calls only, 1.1 adds the batched calls, 1.2 the
    // vector env: every path of each gives the same bytes.
    let expected = run_paths(&study(&new, "v1_2"), &dir.join("out-v1_2"));
    for r in &expected[1..] {
        assert_eq!(&expected[0], r);
    }
    for (lib, name) in [(&v10, "v1_0"), (&v11, "v1_1")] {
        for r in run_paths(&study(lib, name), &dir.join(format!("out-{name}"))) {
            assert_eq!(expected[0], r, "{name}");
        }
    }

    // rwg check: each path a plugin has agrees with its single calls.
    let t = check_text(&v10);
    assert!(
        t.contains("batched calls: no batched calls (an ABI 1.0 plugin"),
        "{t}"
    );
    assert!(t.contains("vector env: no vector env"), "{t}");
    let t = check_text(&v11);
    assert!(
        t.contains("batched calls: reset_many/step_many equal the single calls bit for bit"),
        "{t}"
    );
    assert!(
        t.contains("vector env: no vector env (a plugin before ABI 1.2"),
        "{t}"
    );
    let t = check_text(&new);
    assert!(
        t.contains("batched calls: reset_many/step_many equal the single calls bit for bit"),
        "{t}"
    );
    assert!(
        t.contains("vector env: vec_reset/vec_step equal the single calls bit for bit"),
        "{t}"
    );
}

/// Runs a study of the broken plugin's segfaulting env with `vars`; its
/// standard error, after checking that SIGSEGV killed it.
#[cfg(unix)]
fn segfault_report(name: &str, vars: &[(&str, &str)]) -> String {
    use std::os::unix::process::ExitStatusExt;
    let dir = temp_dir(name);
    let m = manifest(
        &dir,
        &[("broken/SegfaultInStep-v0", &broken_plugin(), "")],
        40,
    );
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
        .env_remove("RWG_PLUGIN_VEC")
        .envs(vars.iter().copied())
        .output()
        .unwrap();
    let err = text(&res.stderr);
    assert_eq!(res.status.signal(), Some(11), "{err}");
    assert!(err.contains("env 'broken/SegfaultInStep-v0'"), "{err}");
    err
}

#[cfg(unix)]
#[test]
fn a_crash_in_a_batched_step_or_a_vector_env_step_is_reported_as_one() {
    // No variable: the vector env is the default.
    let err = segfault_report("vec-segv", &[]);
    assert!(
        err.contains(
            "killed by SIGSEGV (invalid memory access) in vec_step (a vector env's step): "
        ),
        "{err}"
    );
    assert!(
        err.contains("one of 16 lanes (call 2 of the thread; rerun with RWG_PLUGIN_BATCH=0"),
        "{err}"
    );
    let err = segfault_report("batch-segv", &[("RWG_PLUGIN_VEC", "0")]);
    assert!(
        err.contains("killed by SIGSEGV (invalid memory access) in step_many (a batched step): "),
        "{err}"
    );
    assert!(
        err.contains("one of 16 lanes (call 2 of the thread; rerun with RWG_PLUGIN_BATCH=0"),
        "{err}"
    );
}
