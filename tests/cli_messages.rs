//! Messages (issue 12): manifest errors name the key path and line:column,
//! also for non-UTF-8 files; IO errors name their path; no NaN or panic text;
//! one `error:` style; bare file names work; `rwg check` fails an id that
//! shadows a built-in; one median definition, console included.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

const STUDY: &str = r#"
seed = 5
samples = 4
episodes = 3
[[architectures]]
name = "1HL"
hidden = [4]
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 50
"#;

fn manifest(dir: &Path, body: &[u8]) -> String {
    let p = dir.join("m.toml");
    std::fs::write(&p, body).unwrap();
    p.to_str().unwrap().to_string()
}

/// `rwg run` refuses the manifest with `expected` in its one `error:` line
/// and creates nothing.
fn refused(dir: &Path, body: &[u8], expected: &str) {
    let m = manifest(dir, body);
    let out = dir.join("run");
    let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap()]);
    assert!(err.contains(expected), "expected {expected:?} in:\n{err}");
    assert!(err.starts_with("error: "), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!out.exists());
}

#[test]
fn type_errors_name_the_key_path_and_position() {
    let dir = temp_dir("msg-types");
    refused(
        &dir,
        STUDY
            .replace("max_episode_steps = 50", "max_episode_steps = \"0\"")
            .as_bytes(),
        "m.toml:12:21: envs[1].max_episode_steps: expected an integer, found the string \"0\"",
    );
    refused(
        &dir,
        STUDY.replace("samples = 4", "samples = 4.5").as_bytes(),
        "m.toml:3:11: samples: expected an integer, found the float 4.5",
    );
    refused(
        &dir,
        STUDY.replace("hidden = [4]", "hidden = 4").as_bytes(),
        "m.toml:7:10: architectures[0].hidden: expected an array ([...]), found the integer 4",
    );
}

#[test]
fn number_keys_name_their_accepted_forms_not_an_untagged_enum() {
    let dir = temp_dir("msg-num");
    let body = STUDY.replace(
        "max_episode_steps = 50",
        "max_episode_steps = 50\nsolved = \"-100\"",
    );
    let m = manifest(&dir, body.as_bytes());
    let err = rwg_err(&["run", &m, "--out", dir.join("run").to_str().unwrap()]);
    assert!(!err.contains("untagged enum"), "{err}");
    assert!(
        err.contains(
            "m.toml:13:10: envs[1].solved: expected a number (an integer such as 195 or a \
             float such as -140.5), found the string \"-100\""
        ),
        "{err}"
    );
}

#[test]
fn utf16_and_binary_manifests_get_a_position() {
    let dir = temp_dir("msg-bytes");
    let mut utf16 = vec![0xFF, 0xFE];
    for u in STUDY.encode_utf16() {
        utf16.extend(u.to_le_bytes());
    }
    refused(
        &dir,
        &utf16,
        "m.toml:1:1: the file starts with a UTF-16 byte-order mark; the manifest must be UTF-8 TOML",
    );
    refused(
        &dir,
        &utf16[2..],
        "m.toml:2:1: a NUL byte (binary data, or UTF-16 text); the manifest must be UTF-8 TOML",
    );
    let mut latin1 = STUDY.as_bytes().to_vec();
    latin1.extend(b"# caf\xE9\n");
    refused(
        &dir,
        &latin1,
        "m.toml:13:6: byte 0xE9 is not UTF-8; the manifest must be UTF-8 TOML",
    );
}

/// The `median mean` column of the summary, by cell directory.
fn console_medians(stdout: &str) -> Vec<(String, String)> {
    stdout
        .lines()
        .skip_while(|l| !l.starts_with("cell "))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f[0].to_string(), f[2].to_string())
        })
        .collect()
}

#[test]
fn console_median_is_stats_csv_median_and_merge_prints_no_nan() {
    let dir = temp_dir("msg-median");
    let m = manifest(&dir, STUDY.as_bytes());
    let run = dir.join("run");
    let stdout = rwg_ok(&["run", &m, "--out", run.to_str().unwrap()]);
    let console = console_medians(&stdout);
    assert_eq!(console.len(), 2, "{stdout}");
    let stats = std::fs::read_to_string(run.join("stats.csv")).unwrap();
    let header: Vec<&str> = stats.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let mut upper_median_differs = false;
    for (cell, shown) in &console {
        let row: Vec<&str> = stats
            .lines()
            .find(|l| l.split(',').any(|f| f == cell))
            .unwrap_or_else(|| panic!("{cell} not in stats.csv:\n{stats}"))
            .split(',')
            .collect();
        let median: f64 = row[col("median_mean")].parse().unwrap();
        assert_eq!(*shown, format!("{median:.2}"), "{cell}");
        // The old console median (sorted[n/2]) would have shown another value.
        let samples =
            std::fs::read_to_string(run.join("cells").join(cell).join("samples.csv")).unwrap();
        let mut means: Vec<f64> = samples
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        means.sort_by(f64::total_cmp);
        upper_median_differs |= format!("{:.2}", means[means.len() / 2]) != *shown;
    }
    assert!(
        upper_median_differs,
        "the test must tell the two medians apart"
    );

    for k in 0..2 {
        let shard = format!("{k}/2");
        let out = dir.join(format!("s{k}"));
        rwg_ok(&["run", &m, "--shard", &shard, "--out", out.to_str().unwrap()]);
    }
    let merged = dir.join("merged");
    let stdout = rwg_ok(&[
        "merge",
        dir.join("s0").to_str().unwrap(),
        dir.join("s1").to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(!stdout.contains("NaN"), "{stdout}");
    assert_eq!(console_medians(&stdout), console, "{stdout}");
}

#[test]
fn io_errors_name_their_path_once() {
    // a missing run directory is named as such (issue 15), once
    let err = rwg_err(&["stats", "/nonexistent-rwg-run"]);
    assert!(
        err.starts_with("error: /nonexistent-rwg-run is not a run directory (it does not exist)"),
        "{err}"
    );
    assert_eq!(err.matches("/nonexistent-rwg-run").count(), 1, "{err}");
    // any other missing file: its path, the OS error once
    let err = rwg_err(&["run", "/nonexistent-rwg-manifest.toml"]);
    assert!(
        err.starts_with("error: cannot read manifest /nonexistent-rwg-manifest.toml: "),
        "{err}"
    );
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
}

/// Mounts a tmpfs of `kb` KiB (`ro`: read-only) at `at`; false if this
/// machine does not allow it.
fn mount_tmpfs(at: &Path, kb: u32, ro: bool) -> bool {
    std::fs::create_dir_all(at).unwrap();
    let mut opts = format!("size={kb}k");
    if ro {
        opts.push_str(",ro");
    }
    Command::new("mount")
        .args(["-t", "tmpfs", "-o", &opts, "tmpfs"])
        .arg(at)
        .status()
        .is_ok_and(|s| s.success())
}

fn umount(at: &Path) {
    let _ = Command::new("umount").arg(at).status();
}

#[test]
fn read_only_and_full_file_systems_name_the_file() {
    let dir = temp_dir("msg-fs");
    let m = manifest(&dir, STUDY.as_bytes());
    let ro = dir.join("ro");
    if !mount_tmpfs(&ro, 64, true) {
        return skip(
            "read_only_and_full_file_systems_name_the_file",
            "cannot mount a tmpfs (needs root and CAP_SYS_ADMIN)",
        );
    }
    let out = ro.join("run");
    let err = rwg_err(&["run", &m, "--out", out.to_str().unwrap()]);
    umount(&ro);
    assert!(
        err.contains(&format!("cannot create {}", out.display())) && err.contains("Read-only"),
        "{err}"
    );

    // Room for the manifest, run.json, the cells' env.json and a few
    // blocks (a page each at least), not for the whole run.
    let full = dir.join("full");
    assert!(mount_tmpfs(&full, 32, false));
    let out = full.join("run");
    let big = STUDY
        .replace("samples = 4", "samples = 2000")
        .replace("episodes = 3", "episodes = 20");
    let m = manifest(&dir, big.as_bytes());
    let res = Command::new(rwg_bin())
        .args(["run", &m, "--out", out.to_str().unwrap(), "--no-report"])
        .output()
        .unwrap();
    umount(&full);
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(!res.status.success());
    let error_line = err.lines().find(|l| l.starts_with("error: ")).unwrap();
    assert!(error_line.contains("No space left on device"), "{err}");
    assert!(
        error_line.contains("/cells/CartPole-v0__1HL__nobias/"),
        "the error names the file being written, not run.json:\n{err}"
    );
}

#[test]
fn bare_plugin_file_names_are_files_in_the_current_directory() {
    let dir = temp_dir("msg-bare");
    let lib = classic_control_plugin();
    let name = lib.file_name().unwrap();
    std::fs::copy(&lib, dir.join(name)).unwrap();
    let out = Command::new(rwg_bin())
        .current_dir(&dir)
        .arg("check")
        .arg(name)
        .args(["--env", "classic_control/CartPole-v0"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(
        stdout.contains("[ok] load: plugin 'classic_control'"),
        "{stdout}"
    );
    let out = Command::new(rwg_bin())
        .current_dir(&dir)
        .args(["rollout", "classic_control/CartPole-v0", "--actions", "0,1"])
        .arg("--plugin")
        .arg(name)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn check_fails_an_id_that_shadows_a_built_in() {
    let lib = compile_c(
        "shadow",
        "plugins/testing/c/handshake.c",
        "shadow",
        &["ENV_ID=\"CartPole-v0\""],
    );
    let out = rwg(&["check", lib.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(1));
    let results: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let shadow = results
        .iter()
        .find(|r| r["name"] == "built-in id")
        .unwrap_or_else(|| panic!("{results:#?}"));
    assert_eq!(shadow["status"], "failed");
    assert_eq!(shadow["env"], "CartPole-v0");
    assert!(
        shadow["message"]
            .as_str()
            .unwrap()
            .contains("give it a namespace, e.g. 'handshake/CartPole-v0'"),
        "{shadow}"
    );
}

/// A pipe whose reading end is already closed: writing to the other end
/// fails with EPIPE (rwg ignores SIGPIPE, as Rust programs do).
fn closed_pipe() -> std::process::Stdio {
    use std::os::fd::FromRawFd;
    let mut fds = [0; 2];
    // SAFETY: a plain pipe(2); both descriptors are ours.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    unsafe {
        libc::close(fds[0]);
        std::process::Stdio::from(std::os::fd::OwnedFd::from_raw_fd(fds[1]))
    }
}

/// Runs `rwg` with stdout (and, with `both`, stderr) a closed pipe; its
/// exit code and stderr (empty with `both`).
fn rwg_into_closed_pipe(args: &[&str], both: bool) -> (Option<i32>, String) {
    let mut cmd = Command::new(rwg_bin());
    cmd.args(args).stdout(closed_pipe());
    if both {
        cmd.stderr(closed_pipe());
    }
    let out = cmd.output().expect("cannot run rwg");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn a_closed_pipe_is_exit_141_or_the_commands_own_failure() {
    let run = synthetic_run("msg-pipe", 64, 2);
    let damaged = synthetic_run("msg-pipe-damaged", 64, 2);
    let scores = std::fs::read_dir(damaged.join("cells"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path()
        .join("scores.csv");
    let mut text = std::fs::read_to_string(&scores).unwrap();
    text.push_str("63,1,1.0,1\n");
    std::fs::write(&scores, text).unwrap();
    let d = damaged.to_str().unwrap();
    // `rwg verify DAMAGED | true`: the mismatch is still exit 1, told on stderr
    let (code, err) = rwg_into_closed_pipe(&["verify", d], false);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.starts_with("error: ") && err.contains("problem(s)"),
        "{err}"
    );
    assert!(!err.contains("internal error"), "{err}");
    // `rwg verify DAMAGED 2>&1 | head -1`: no abort, still exit 1
    assert_eq!(rwg_into_closed_pipe(&["verify", d], true).0, Some(1));
    // a command that succeeds but whose output is lost: 141, as SIGPIPE
    let r = run.to_str().unwrap();
    for args in [
        &["verify", r][..],
        &["envs"],
        &["stats", r],
        &["top", r],
        &["--help"],
        &["--version"],
        &["rollout", "CartPole-v0", "--actions", "0,1,0"],
    ] {
        let (code, err) = rwg_into_closed_pipe(args, false);
        assert_eq!(code, Some(141), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?}: {err}");
        assert_eq!(rwg_into_closed_pipe(args, true).0, Some(141), "{args:?}");
    }
    // a usage error keeps clap's status 2
    assert_eq!(rwg_into_closed_pipe(&["verify"], true).0, Some(2));
    // `rwg stats RUN | head -1` of a table the pipe holds whole: written
    // before head reads it, so 0, as docs/reference.md says (`seq 10 | head -1`)
    let out = Command::new("bash")
        .args([
            "-c",
            "set -o pipefail; \"$0\" stats \"$1\" | head -1 >/dev/null",
        ])
        .arg(rwg_bin())
        .arg(r)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
}

#[test]
fn a_full_stdout_is_an_error_naming_it() {
    // Linux's device whose every write fails with ENOSPC
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full");
    for args in [&["envs"][..], &["--version"], &["stats", "--help"]] {
        let out = Command::new(rwg_bin())
            .args(args)
            .stdout(full.try_clone().unwrap())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(
            err.trim_end(),
            "error: cannot write to standard output: No space left on device (os error 28)",
            "{args:?}"
        );
    }
}

#[test]
fn arguments_that_are_not_utf8_or_not_directories_are_named() {
    use std::os::unix::ffi::OsStrExt;
    let dir = temp_dir("msg-args");
    let m = manifest(&dir, STUDY.as_bytes());
    // a manifest whose name is not UTF-8: the run's lock file names it
    let odd = dir.join(std::ffi::OsStr::from_bytes(b"m\xFF.toml"));
    std::fs::copy(&m, &odd).unwrap();
    let out = dir.join("run-odd");
    let o = Command::new(rwg_bin())
        .arg("run")
        .arg(&odd)
        .args(["--out", out.to_str().unwrap(), "--no-report", "-q"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // an error with such an argument on the command line (the hint looks at them)
    let o = Command::new(rwg_bin())
        .arg("stats")
        .arg(dir.join(std::ffi::OsStr::from_bytes(b"no\xFFrun")))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with("error: ") && err.contains("is not a run directory"),
        "{err}"
    );
    assert!(!err.contains("internal error"), "{err}");
    // --out naming a file
    let file = dir.join("a-file");
    std::fs::write(&file, "precious\n").unwrap();
    let err = rwg_err(&["run", &m, "--out", file.to_str().unwrap()]);
    assert_eq!(
        err.trim_end(),
        format!(
            "error: {}: exists and is not a directory; the run directory (--out, or `out` in \
             the manifest) must be a directory or not exist yet",
            file.display()
        )
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "precious\n");
}

#[test]
fn named_output_files_that_are_links_or_fifos_are_written_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = temp_dir("msg-named-out");
    let m = manifest(&dir, STUDY.as_bytes());
    let run = dir.join("run");
    rwg_ok(&[
        "run",
        &m,
        "--out",
        run.to_str().unwrap(),
        "--no-report",
        "-q",
    ]);
    let export = |to: &Path| {
        rwg_ok(&[
            "replay",
            run.to_str().unwrap(),
            "--env",
            "CartPole-v0",
            "--arch",
            "1HL",
            "--sample",
            "3",
            "--export-weights",
            to.to_str().unwrap(),
        ])
    };
    // a symbolic link: its target is written, the link stays
    let target = dir.join("weights.json");
    std::fs::write(&target, "old\n").unwrap();
    let link = dir.join("link.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    export(&link);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&target)
        .unwrap()
        .contains("\"weights\""));
    // a FIFO (as a device would be): written into, not renamed over
    let fifo = dir.join("fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: plain calls on a path of our own; the read end is opened
    // non-blocking first so that rwg's open for writing does not wait.
    let fd = unsafe {
        assert_eq!(libc::mkfifo(c.as_ptr(), 0o600), 0);
        libc::open(c.as_ptr(), libc::O_RDONLY | libc::O_NONBLOCK)
    };
    assert!(fd >= 0);
    export(&fifo);
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let mut buf = vec![0u8; 1 << 16];
    // SAFETY: a live buffer and our descriptor.
    let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
    unsafe { libc::close(fd) };
    assert!(n > 0, "nothing arrived through the FIFO");
    assert!(String::from_utf8_lossy(&buf[..n as usize]).contains("\"weights\""));
}

#[test]
fn a_file_where_a_directory_goes_is_named_in_a_hint() {
    let dir = temp_dir("msg-file-not-dir");
    let m = manifest(&dir, STUDY.as_bytes());
    let shards: Vec<String> = (0..2)
        .map(|k| {
            let s = dir.join(format!("s{k}"));
            rwg_ok(&[
                "run",
                &m,
                "--shard",
                &format!("{k}/2"),
                "--out",
                s.to_str().unwrap(),
                "-q",
            ]);
            s.to_str().unwrap().to_string()
        })
        .collect();
    let file = dir.join("a-file");
    std::fs::write(&file, "precious\n").unwrap();
    let f = file.to_str().unwrap();
    let hint = format!(
        "hint: {f} is a file, not a directory: name a directory (or a path that does not exist yet)"
    );
    let run = dir.join("run");
    rwg_ok(&[
        "run",
        &m,
        "--out",
        run.to_str().unwrap(),
        "--no-report",
        "-q",
    ]);
    for args in [
        vec!["merge", &shards[0], &shards[1], "--out", f],
        vec!["plot", run.to_str().unwrap(), "--out", f],
    ] {
        let err = rwg_err(&args);
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert_eq!(err.lines().nth(1), Some(hint.as_str()), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "precious\n");
}
