//! Input limits (issue 12): every count, size and name of a manifest or a
//! flag is checked against a documented maximum when the study is loaded,
//! with the limit in the message, before anything is written; never an
//! allocation abort, a panic or a hang.

mod common;
use common::*;
use std::path::Path;
use std::time::{Duration, Instant};

const STUDY: &str = r#"
samples = 4
episodes = 2
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v0"
"#;

fn manifest(dir: &Path, body: &str) -> String {
    let p = dir.join("m.toml");
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// Runs `rwg run` expecting a refusal that contains `expected`, promptly,
/// without panic text, and without creating the run directory.
fn refused(dir: &Path, body: &str, flags: &[&str], expected: &str) {
    let m = manifest(dir, body);
    let out = dir.join("run");
    let mut args = vec!["run", m.as_str(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(flags);
    let t0 = Instant::now();
    let err = rwg_err(&args);
    assert!(
        t0.elapsed() < Duration::from_secs(30),
        "{args:?} took too long"
    );
    assert!(err.contains(expected), "expected {expected:?} in:\n{err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists(), "{args:?}: nothing may be created on disk");
}

#[test]
fn huge_episode_counts_are_refused_before_allocating() {
    let dir = temp_dir("limits-episodes");
    refused(
        &dir,
        &STUDY.replace("episodes = 2", "episodes = 4294967295"),
        &[],
        "m.toml:3:12: episodes: at most 10000 (rwg's limit), got 4294967295",
    );
    refused(
        &dir,
        STUDY,
        &["--episodes", "4294967295"],
        "--episodes: at most 10000 (rwg's limit), got 4294967295",
    );
}

#[test]
fn huge_sample_counts_do_not_panic() {
    let dir = temp_dir("limits-samples");
    refused(
        &dir,
        STUDY,
        &["--samples", "9223372036854775808"],
        "--samples: at most 10000000 (rwg's limit), got 9223372036854775808",
    );
    refused(
        &dir,
        &STUDY.replace("samples = 4", "samples = 9223372036854775807"),
        &[],
        "m.toml:2:11: samples: at most 10000000 (rwg's limit), got 9223372036854775807",
    );
}

#[test]
fn huge_thread_counts_do_not_hang() {
    let dir = temp_dir("limits-threads");
    refused(
        &dir,
        STUDY,
        &["--threads", "100000"],
        "--threads: at most 1024 (rwg's limit), got 100000",
    );
    refused(
        &dir,
        &STUDY.replace("episodes = 2", "episodes = 2\nthreads = 100000"),
        &[],
        "m.toml:4:11: threads: at most 1024 (rwg's limit), got 100000",
    );
}

#[test]
fn long_names_fail_at_load_not_at_run_time() {
    let dir = temp_dir("limits-names");
    let long = "a".repeat(5000);
    refused(
        &dir,
        &STUDY.replace("name = \"0HL\"", &format!("name = \"{long}\"")),
        &[],
        "m.toml:5:8: architectures[0].name: at most 64 bytes (rwg's limit), got 5000",
    );
    refused(
        &dir,
        &STUDY.replace("CartPole-v0", &long),
        &[],
        "m.toml:8:6: envs[0].id: at most 128 bytes (rwg's limit), got 5000",
    );
}

#[test]
fn layers_and_weights_are_limited() {
    let dir = temp_dir("limits-weights");
    refused(
        &dir,
        &STUDY.replace("hidden = []", "hidden = [4096, 4096]"),
        &[],
        "envs[0]: architectures[0] '0HL' on 'CartPole-v0' has 16801792 weights per network; \
         at most 1000000 (rwg's limit)",
    );
    refused(
        &dir,
        &STUDY.replace("hidden = []", "hidden = [100000]"),
        &[],
        "architectures[0].hidden[0]: a layer needs 1 to 4096 units (rwg's limit), got 100000",
    );
    refused(
        &dir,
        &STUDY.replace(
            "id = \"CartPole-v0\"",
            "id = \"CartPole-v0\"\nmax_episode_steps = 4294967295",
        ),
        &[],
        "envs[0].max_episode_steps: at most 10000000 (rwg's limit), got 4294967295",
    );
}

#[test]
fn shard_counts_and_bench_flags_are_limited() {
    let dir = temp_dir("limits-flags");
    refused(
        &dir,
        STUDY,
        &["--shard", "0/18446744073709551615"],
        "at most 100000 shards (rwg's limit)",
    );
    let err = rwg_err(&["bench", "sampler", "--samples", "18446744073709551615"]);
    assert!(
        err.contains("--samples: at most 10000000 (rwg's limit), got 18446744073709551615"),
        "{err}"
    );
    let err = rwg_err(&["bench", "sampler", "--threads", "100000"]);
    assert!(err.contains("--threads: at most 1024"), "{err}");
    let err = rwg_err(&["bench", "envs", "--steps", "18446744073709551615"]);
    assert!(err.contains("--steps: at most 10000000000"), "{err}");
    let err = rwg_err(&[
        "rollout",
        "CartPole-v0",
        "--actions",
        "0",
        "--max-episode-steps",
        "4294967295",
    ]);
    assert!(
        err.contains("--max-episode-steps: at most 10000000"),
        "{err}"
    );
}

#[test]
fn oversized_manifest_files_are_refused_unread() {
    let dir = temp_dir("limits-file");
    let mut body = STUDY.to_string();
    body.push_str(&format!("# {}\n", "x".repeat(1 << 20)));
    refused(
        &dir,
        &body,
        &[],
        &format!(
            "m.toml:1:1: the file has {} bytes; a manifest has at most 1048576 (rwg's limit)",
            body.len()
        ),
    );
}

#[test]
fn seeds_past_the_largest_toml_integer_are_refused_by_name() {
    let dir = temp_dir("limits-seed");
    for seed in ["9223372036854775808", "18446744073709551615"] {
        refused(
            &dir,
            STUDY,
            &["--seed", seed],
            &format!("--seed: at most 9223372036854775807 (rwg's limit), got {seed}"),
        );
    }
    refused(
        &dir,
        &format!("seed = 18446744073709551615\n{STUDY}"),
        &[],
        "m.toml:1:8: seed: number too large to fit in target type: a TOML integer is from \
         -9223372036854775808 to 9223372036854775807",
    );
    // the largest one runs
    let m = manifest(&dir, STUDY);
    let out = dir.join("max");
    rwg_ok(&[
        "run",
        &m,
        "--out",
        out.to_str().unwrap(),
        "--seed",
        "9223372036854775807",
        "--no-report",
        "-q",
    ]);
    let resolved = std::fs::read_to_string(out.join("manifest.toml")).unwrap();
    assert!(
        resolved.contains("seed = 9223372036854775807"),
        "{resolved}"
    );
}

#[test]
fn every_rwg_variable_is_checked_before_anything_is_created() {
    let dir = temp_dir("limits-vars");
    let m = manifest(&dir, STUDY);
    let out = dir.join("run");
    let bad = [
        ("RWG_PROGRESS_INTERVAL", "1e30", "seconds from 0 to 86400"),
        ("RWG_PROGRESS_INTERVAL", "-1", "seconds from 0 to 86400"),
        ("RWG_PROGRESS_INTERVAL", "nan", "seconds from 0 to 86400"),
        ("RWG_PROGRESS_INTERVAL", "abc", "seconds from 0 to 86400"),
        ("RWG_GYM_TIMEOUT", "1e30", "seconds from 0.001 to 604800"),
        ("RWG_GYM_TIMEOUT", "0", "seconds from 0.001 to 604800"),
        ("RWG_GYM_TIMEOUT", "-1", "seconds from 0.001 to 604800"),
        ("RWG_GYM_TIMEOUT", "nan", "seconds from 0.001 to 604800"),
        ("RWG_GYM_TIMEOUT", "abc", "seconds from 0.001 to 604800"),
        (
            "RWG_GYM_START_TIMEOUT",
            "1e30",
            "seconds from 0.001 to 604800",
        ),
        ("RWG_GYM_START_TIMEOUT", "0", "seconds from 0.001 to 604800"),
        ("RWG_JAX_TIMEOUT", "0", "seconds from 0.001 to 604800"),
        ("RWG_JAX_TIMEOUT", "1e30", "seconds from 0.001 to 604800"),
        ("RWG_JAX_TIMEOUT", "abc", "seconds from 0.001 to 604800"),
        ("RWG_COMMIT_LINGER", "inf", "seconds from 0 to 3600"),
        ("RWG_LOCKSTEP", "no", "0 or 1"),
        ("RWG_SIMD", "avx1024", "one of scalar, avx2, avx512"),
        ("RWG_SIMD", "AVX2", "one of scalar, avx2, avx512"),
        ("RWG_PLUGIN_BATCH", "false", "0 or 1"),
        ("RWG_PLUGIN_VEC", "2", "0 or 1"),
    ];
    for (var, value, expected) in bad {
        let o = rwg_env(
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
            &[(var, std::ffi::OsStr::new(value))],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{var}={value}: {err}");
        assert!(
            err.starts_with(&format!("error: {var}={value}: expected {expected} (")),
            "{var}={value}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!out.exists(), "{var}={value}: nothing may be created");
    }
    // a SIMD level this CPU lacks (none on a CPU with AVX-512)
    for level in rwg_env::simd::Simd::ALL {
        if level.available() {
            continue;
        }
        let o = rwg_env(
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
            &[("RWG_SIMD", std::ffi::OsStr::new(level.name()))],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "RWG_SIMD={level}: {err}");
        assert!(
            err.starts_with(&format!(
                "error: RWG_SIMD={level}: expected a level this CPU has: "
            )),
            "{err}"
        );
        assert!(!out.exists(), "RWG_SIMD={level}: nothing may be created");
    }
    // not UTF-8
    use std::os::unix::ffi::OsStrExt;
    let o = rwg_env(
        &["envs"],
        &[("RWG_PYTHON", std::ffi::OsStr::from_bytes(b"py\xFFthon"))],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with("error: RWG_PYTHON=py\u{FFFD}thon: expected text in UTF-8"),
        "{err}"
    );
    // set to the empty string: refused, not taken as unset
    for var in [
        "RWG_PROGRESS_INTERVAL",
        "RWG_COMMIT_LINGER",
        "RWG_GYM_TIMEOUT",
        "RWG_GYM_START_TIMEOUT",
        "RWG_JAX_TIMEOUT",
        "RWG_PYTHON",
        "RWG_PLUGIN_PATH",
        "RWG_PLUGIN_VEC",
        "RWG_PLUGIN_BATCH",
        "RWG_LOCKSTEP",
        "RWG_SIMD",
        "RWG_PEER_PYTHON",
        "RWG_PEERS_DIR",
    ] {
        let o = rwg_env(
            &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
            &[(var, std::ffi::OsStr::new(""))],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{var}=: {err}");
        assert!(
            err.starts_with(&format!("error: {var}=: expected ")),
            "{var}=: {err}"
        );
        assert!(
            err.trim_end().ends_with(&format!(
                "; {var} is set to the empty string: unset it (`unset {var}`) for the default"
            )),
            "{var}=: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!out.exists(), "{var}=: nothing may be created");
    }
    // good values run
    let o = rwg_env(
        &["run", &m, "--out", out.to_str().unwrap(), "--no-report"],
        &[
            ("RWG_PROGRESS_INTERVAL", std::ffi::OsStr::new("0.5")),
            ("RWG_GYM_TIMEOUT", std::ffi::OsStr::new("2.5")),
            ("RWG_COMMIT_LINGER", std::ffi::OsStr::new("0")),
            ("RWG_LOCKSTEP", std::ffi::OsStr::new("1")),
            ("RWG_SIMD", std::ffi::OsStr::new("scalar")),
            ("RWG_PLUGIN_BATCH", std::ffi::OsStr::new("1")),
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn endless_input_files_are_read_to_their_limit_only() {
    let dir = temp_dir("limits-endless");
    let t0 = Instant::now();
    // a manifest that states no size and never ends
    let out = dir.join("run");
    let err = rwg_err(&["run", "/dev/zero", "--out", out.to_str().unwrap()]);
    assert_eq!(
        err.trim_end(),
        "error: /dev/zero:1:1: the file holds more than 1048576 bytes; a manifest has at most \
         1048576 (rwg's limit)"
    );
    assert!(!out.exists());
    // an actions file
    let err = rwg_err(&["rollout", "CartPole-v0", "--actions-file", "/dev/zero"]);
    assert!(
        err.starts_with(
            "error: cannot read actions file /dev/zero: it has more than 268435456 bytes"
        ),
        "{err}"
    );
    // a run's run.json that has become a device
    let run = synthetic_run("limits-endless-run", 32, 2);
    std::fs::remove_file(run.join("run.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", run.join("run.json")).unwrap();
    let err = rwg_err(&["stats", run.to_str().unwrap()]);
    // (a file of rwg's own: only a regular file is read, up to its limit)
    assert!(
        err.contains("run.json") && err.contains("not a regular file"),
        "{err}"
    );
    assert!(!err.contains("internal error"), "{err}");
    assert!(
        t0.elapsed() < Duration::from_secs(60),
        "took {:?}",
        t0.elapsed()
    );
}

#[test]
fn run_files_that_are_devices_fail_at_once() {
    let run = synthetic_run("limits-device-cell", 32, 2);
    let cell = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let scores = cell.join("scores.csv");
    std::fs::remove_file(&scores).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &scores).unwrap();
    let r = run.to_str().unwrap();
    for args in [&["verify", r][..], &["stats", r, "--no-write"]] {
        let t0 = Instant::now();
        let o = rwg(args);
        // (verify names each problem on stdout)
        let err = String::from_utf8_lossy(&o.stderr) + String::from_utf8_lossy(&o.stdout);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(&*scores.to_string_lossy()) && err.contains("not a regular file"),
            "{args:?}: {err}"
        );
        assert!(t0.elapsed() < Duration::from_secs(30), "{args:?}");
    }
}

#[test]
fn run_files_that_are_fifos_are_not_waited_on() {
    let run = synthetic_run("limits-fifo-run", 32, 2);
    let meta = run.join("run.json");
    std::fs::remove_file(&meta).unwrap();
    let c = std::ffi::CString::new(meta.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a path of our own.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let t0 = Instant::now();
    let err = rwg_err(&["stats", run.to_str().unwrap(), "--no-write"]);
    assert!(
        err.contains("run.json") && err.contains("not a regular file"),
        "{err}"
    );
    assert!(t0.elapsed() < Duration::from_secs(30));
}
