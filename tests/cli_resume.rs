//! The command `rwg run` prints to resume a run, after Ctrl-C or a plugin's
//! crash, works as printed: whatever overrides the run had (`--samples`,
//! `--seed`, ...) and whatever characters its paths hold, running the
//! printed line in a shell finishes the study with the bytes of an
//! uninterrupted run.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Output};

/// Two envs, two architectures, overridden on the command line below.
const STUDY: &str = r#"
seed = 3
samples = 40
episodes = 2
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL"
hidden = [3]
[[envs]]
id = "CartPole-v1"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 100
"#;

/// Runs `line` in `sh` in `cwd` as a user would paste it, with this
/// build's `rwg` first on PATH.
fn run_in_shell(cwd: &Path, line: &str) -> Output {
    let bin_dir = rwg_bin().parent().unwrap().to_path_buf();
    let path = std::env::join_paths(std::iter::once(bin_dir).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .unwrap();
    Command::new("sh")
        .args(["-c", line])
        .current_dir(cwd)
        .env("PATH", path)
        .output()
        .unwrap()
}

/// The command after `marker` in `stderr`: on the same line, or on the
/// next one when the marker ends its line.
fn printed_command(stderr: &str, marker: &str) -> String {
    let at = stderr
        .find(marker)
        .unwrap_or_else(|| panic!("{marker:?} missing in:\n{stderr}"));
    let rest = stderr[at + marker.len()..].trim_start_matches([' ', '\n']);
    let line = rest.lines().next().unwrap().trim().to_string();
    assert!(line.starts_with("rwg run "), "{line:?} in:\n{stderr}");
    line
}

/// The files of a finished run that must be byte-identical.
fn assert_same_results(a: &Path, b: &Path, cells: &[&str], files: &[&str]) {
    for cell in cells {
        for f in files {
            let p = format!("cells/{cell}/{f}");
            assert!(
                std::fs::read(a.join(&p)).unwrap() == std::fs::read(b.join(&p)).unwrap(),
                "{p} differs between {} and {}",
                a.display(),
                b.display()
            );
        }
    }
}

#[cfg(unix)]
#[test]
fn after_ctrl_c_the_printed_command_resumes_a_run_with_overrides() {
    // Spaces, a quote and a leading dash in the paths: the command must
    // survive a shell.
    let dir = temp_dir("resume it's");
    let m = dir.join("-study.toml");
    std::fs::write(&m, STUDY).unwrap();
    let out = dir.join("-run d");
    let overrides = ["--samples", "2000", "--seed", "11", "--episodes", "3"];
    let mut cmd = Command::new(rwg_bin());
    cmd.current_dir(&dir)
        .args([
            "run",
            "./-study.toml",
            "--out",
            "./-run d",
            "--threads",
            "2",
        ])
        .args(overrides)
        .env("RWG_COMMIT_LINGER", "0");
    let err = ctrl_c_after_first_block(cmd, &out.join("cells/CartPole-v1__0HL__nobias/blocks"));
    let line = printed_command(&err, "Resume with:");
    let res = run_in_shell(&dir, &line);
    assert!(
        res.status.success(),
        "{line}\nfailed: {}",
        String::from_utf8_lossy(&res.stderr)
    );
    let reference = dir.join("reference");
    let mut args = vec![
        "run",
        m.to_str().unwrap(),
        "--out",
        reference.to_str().unwrap(),
    ];
    args.extend(overrides);
    rwg_ok(&args);
    assert!(
        std::fs::read(out.join("manifest.toml")).unwrap()
            == std::fs::read(reference.join("manifest.toml")).unwrap()
    );
    let cells = [
        "CartPole-v1__0HL__nobias",
        "CartPole-v1__1HL__nobias",
        "Acrobot-v1__0HL__nobias",
        "Acrobot-v1__1HL__nobias",
    ];
    assert_same_results(&out, &reference, &cells, &["scores.csv", "samples.csv"]);
    assert!(
        std::fs::read(out.join("stats.csv")).unwrap()
            == std::fs::read(reference.join("stats.csv")).unwrap()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A study of the broken plugin's env that exits at its 250th reset.
fn exiting_study(dir: &Path, name: &str, at_reset: u32) -> String {
    let body = format!(
        "samples = 32\nepisodes = 3\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"broken/ExitInReset-v0\"\nplugin = \"{}\"\nconfig = \"at_reset={at_reset}\"\n",
        broken_plugin().display()
    );
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn after_a_plugin_s_crash_the_printed_command_resumes_a_run_with_overrides() {
    let dir = temp_dir("resume after crash");
    // The plugin exits at its 250th reset: blocks 0 and 1 (2 x 32 networks
    // x 3 episodes = 192 resets) are committed first with one thread; the
    // resumed run (a new process) has 96 resets to do.
    let m = exiting_study(&dir, "f.toml", 250);
    let out = dir.join("run d");
    let run = |manifest: &str, out: &Path| {
        rwg_env(
            &[
                "run",
                manifest,
                "--out",
                out.to_str().unwrap(),
                "--no-report",
                "--samples",
                "96",
                "--threads",
                "1",
            ],
            &[("RWG_PLUGIN_BATCH", "0".as_ref())],
        )
    };
    let res = run(&m, &out);
    let err = String::from_utf8_lossy(&res.stderr).into_owned();
    assert_eq!(res.status.code(), Some(1), "{err}");
    let line = printed_command(&err, "resume with: ");
    let res = run_in_shell(&std::env::temp_dir(), &line);
    assert!(
        res.status.success(),
        "{line}\nfailed: {}",
        String::from_utf8_lossy(&res.stderr)
    );
    let clean = exiting_study(&dir, "c.toml", 100_000);
    let reference = dir.join("clean");
    assert!(run(&clean, &reference).status.success());
    let cell = "broken+ExitInReset-v0__0HL__nobias";
    assert_same_results(&out, &reference, &[cell], &["scores.csv", "samples.csv"]);
    let _ = std::fs::remove_dir_all(&dir);
}
