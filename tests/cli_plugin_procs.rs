//! What a plugin does to the process it runs in (`plugins/testing/c/hostile.c`):
//! the daemons it forks end with rwg (in-process, isolated, and under `rwg
//! check`, whose checks no longer wait on the daemons' pipes); rwg stops on
//! Ctrl-C and SIGTERM whatever the plugin set their handling to; a plugin's
//! `alarm()`, an exit handler that aborts after a complete run and an error
//! text full of terminal escape sequences each get a message; a plugin
//! that silences fd 2 does not silence rwg.

#![cfg(target_os = "linux")]

mod common;
use common::*;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// `libhostile.so` built with `defines`, in a folder of its own for `name`.
fn hostile(name: &str, defines: &[&str]) -> PathBuf {
    compile_c(
        &format!("procs-{name}"),
        "plugins/testing/c/hostile.c",
        "hostile",
        defines,
    )
}

/// A study of `samples` networks x 2 episodes of hostile/Counter-v0.
fn study(dir: &Path, lib: &Path, samples: u32) -> String {
    let p = dir.join("m.toml");
    std::fs::write(
        &p,
        format!(
            "samples = {samples}\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = \
             []\n[[envs]]\nid = \"hostile/Counter-v0\"\nplugin = {:?}\n",
            lib.to_str().unwrap()
        ),
    )
    .unwrap();
    p.to_str().unwrap().to_string()
}

/// `rwg ARGS` with the pid folder `pids` and the signals at their default
/// action (whatever this test inherited), in a process group of its own,
/// its output into files in `pids`' parent (a pipe would keep the test
/// waiting for ever on a daemon that inherited it).
fn rwg_cmd(args: &[&str], pids: &Path) -> Command {
    let logs = pids.parent().unwrap();
    let file = |name: &str| std::fs::File::create(logs.join(name)).unwrap();
    let mut c = Command::new(rwg_bin());
    c.args(args)
        .env("HOSTILE_PIDS", pids)
        .env_remove("RWG_PLUGIN_PATH")
        .stdout(file("stdout"))
        .stderr(file("stderr"))
        .process_group(0);
    // SAFETY: signal(2) is async-signal-safe, the only call between fork and exec.
    unsafe {
        c.pre_exec(|| {
            for s in [libc::SIGHUP, libc::SIGINT, libc::SIGTERM, libc::SIGALRM] {
                libc::signal(s, libc::SIG_DFL);
            }
            Ok(())
        });
    }
    c
}

/// How rwg ended: its status and output.
struct Ended {
    status: ExitStatus,
    stdout: String,
    stderr: String,
}

/// Waits up to `limit` for `child` (started by [`rwg_cmd`] with `pids`) to
/// end, else kills its group and fails.
fn finish(mut child: Child, pids: &Path, limit: Duration, what: &str) -> Ended {
    let logs = pids.parent().unwrap();
    let read = |name: &str| std::fs::read_to_string(logs.join(name)).unwrap_or_default();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > limit {
            // SAFETY: killing the test's own child's process group.
            unsafe {
                libc::kill(-(child.id() as i32), libc::SIGKILL);
            }
            let _ = child.wait();
            for p in daemons(pids) {
                // SAFETY: killing the test's strays.
                unsafe {
                    libc::kill(p as i32, libc::SIGKILL);
                }
            }
            panic!(
                "{what}: rwg did not end within {limit:?}:\n{}",
                read("stderr")
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    Ended {
        status,
        stdout: read("stdout"),
        stderr: read("stderr"),
    }
}

/// The process ids the plugin's daemons wrote into `pids`.
fn daemons(pids: &Path) -> Vec<u32> {
    std::fs::read_dir(pids)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().parse().unwrap())
        .collect()
}

/// Fails (after killing them) if any of the daemons in `pids` still runs
/// two seconds after rwg ended.
fn all_ended(what: &str, pids: &Path) {
    let started = daemons(pids);
    assert!(!started.is_empty(), "{what}: the plugin started no daemon");
    let t0 = Instant::now();
    while started.iter().any(|&p| alive(p)) && t0.elapsed() < Duration::from_secs(2) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let left: Vec<u32> = started.iter().copied().filter(|&p| alive(p)).collect();
    for &p in &left {
        // SAFETY: killing the test's strays.
        unsafe {
            libc::kill(p as i32, libc::SIGKILL);
        }
    }
    assert!(
        left.is_empty(),
        "{what}: the plugin's daemons {left:?} outlived rwg"
    );
}

fn fresh(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    let _ = std::fs::remove_dir_all(&p);
    std::fs::create_dir_all(&p).unwrap();
    p
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A plugin that forks a helper which calls setsid, and the helper a daemon
/// that calls setsid again: both end with rwg, in-process and isolated,
/// when the run ends, and under `rwg check` (which waited for ever on the
/// daemons' hold of its child's pipes).
#[test]
fn a_plugins_daemons_end_with_rwg() {
    let dir = temp_dir("procs-daemons");
    let lib = hostile("daemons", &["SPAWN_DAEMONS"]);
    let m = study(&dir, &lib, 64);
    for (what, isolate) in [("in-process", false), ("isolated", true)] {
        let pids = fresh(&dir, &format!("pids-{isolate}"));
        let out = dir.join(format!("run-{isolate}"));
        let mut args = vec!["run", &m, "--out", path_str(&out), "--no-report", "-q"];
        if isolate {
            args.push("--isolate");
        }
        let res = finish(
            rwg_cmd(&args, &pids).spawn().unwrap(),
            &pids,
            Duration::from_secs(90),
            what,
        );
        assert!(res.status.success(), "{what}: {}", res.stderr);
        all_ended(what, &pids);
    }
    let pids = fresh(&dir, "pids-check");
    let res = finish(
        rwg_cmd(&["check", path_str(&lib)], &pids).spawn().unwrap(),
        &pids,
        Duration::from_secs(90),
        "rwg check",
    );
    assert!(res.status.success(), "rwg check: {}", res.stdout);
    all_ended("rwg check", &pids);
    let _ = std::fs::remove_dir_all(&dir);
}

/// rwg's children that are zombies.
fn zombies(rwg: u32) -> Vec<u32> {
    children(rwg)
        .into_iter()
        .filter(|&c| {
            std::fs::read_to_string(format!("/proc/{c}/stat"))
                .is_ok_and(|s| s[s.rfind(')').unwrap() + 2..].starts_with('Z'))
        })
        .collect()
}

/// A plugin whose daemons exit (50 double forks, one per reset) leaves rwg,
/// their subreaper, with no zombies to hold process ids: rwg reaps them
/// while the run goes on.
#[test]
fn orphans_that_end_are_reaped_during_the_run() {
    let dir = temp_dir("procs-orphans");
    let lib = hostile("orphans", &["ORPHAN_PER_RESET", "SLEEP_IN_STEP_MS=2"]);
    let m = study(&dir, &lib, 100_000);
    let pids = fresh(&dir, "pids");
    let out = dir.join("run");
    let args = ["run", &m, "--out", path_str(&out), "--no-report", "-q"];
    let mut child = rwg_cmd(&args, &pids)
        .args(["--threads", "1"])
        .spawn()
        .unwrap();
    // 50 resets of 20 steps of 2 ms take about 2 s; then 4 s more
    let t0 = Instant::now();
    let mut most = 0;
    let mut left = vec![];
    while t0.elapsed() < Duration::from_secs(7) {
        left = zombies(child.id());
        most = most.max(left.len());
        std::thread::sleep(Duration::from_millis(100));
    }
    // SAFETY: killing the test's own child's process group.
    unsafe {
        libc::kill(-(child.id() as i32), libc::SIGKILL);
    }
    let _ = child.wait();
    assert!(most > 0, "the plugin left no orphan to reap");
    assert!(left.is_empty(), "zombies {left:?} still held after 7 s");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts a long run of a plugin built with `defines` (each step sleeps
/// 1 ms), waits for its first committed block, sends `signal` to rwg alone
/// (`to_group`: to its whole process group, as a terminal's Ctrl-C does) and
/// returns how rwg ended.
fn signalled(name: &str, defines: &[&str], signal: i32, to_group: bool) -> (Ended, PathBuf) {
    let dir = temp_dir(&format!("procs-{name}"));
    let mut defs = defines.to_vec();
    defs.push("SLEEP_IN_STEP_MS=1");
    let lib = hostile(name, &defs);
    let m = study(&dir, &lib, 100_000);
    let pids = fresh(&dir, "pids");
    let out = dir.join("run");
    let args = ["run", &m, "--out", path_str(&out), "--no-report"];
    let child = rwg_cmd(&args, &pids)
        .args(["--threads", "2"])
        .env("RWG_COMMIT_LINGER", "0")
        .spawn()
        .unwrap();
    let first = out.join("cells/hostile+Counter-v0__0HL__nobias/blocks/b0000000.csv");
    let t0 = Instant::now();
    while !first.exists() && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(first.exists(), "{name}: no block was committed");
    let target = if to_group {
        -(child.id() as i32)
    } else {
        child.id() as i32
    };
    // SAFETY: signalling the test's own child (or its group).
    unsafe {
        libc::kill(target, signal);
    }
    (finish(child, &pids, Duration::from_secs(30), name), dir)
}

/// A plugin that sets SIGINT, SIGTERM and SIGHUP to be ignored (in its
/// `init`) cannot make rwg unstoppable: Ctrl-C stops the run (status 130,
/// every block kept), SIGTERM ends it with a message and how to resume.
#[test]
fn rwg_stops_whatever_a_plugin_does_to_its_signals() {
    let (res, dir) = signalled("ignore-int", &["IGNORE_SIGNALS"], libc::SIGINT, true);
    let err = &res.stderr;
    assert_eq!(res.status.code(), Some(130), "{err}");
    assert!(
        err.contains("stopped; every finished block is saved in"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);

    let (res, dir) = signalled("ignore-term", &["IGNORE_SIGNALS"], libc::SIGTERM, false);
    let err = &res.stderr;
    assert_eq!(res.status.signal(), Some(libc::SIGTERM), "{err}");
    assert!(
        err.contains("warning: code running in rwg's process (an in-process plugin) set SIGTERM to be ignored; rwg put back its own handling"),
        "{err}"
    );
    assert!(
        err.contains("error: rwg received SIGTERM (a request to end"),
        "{err}"
    );
    assert!(err.contains("Every committed block is kept in "), "{err}");
    assert!(err.contains("resume with: rwg run "), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plugin that points fd 2 at /dev/null, or closes fds 1 and 2, silences
/// itself, not rwg: rwg's messages (here SIGTERM's) still reach its stderr.
#[test]
fn rwg_speaks_whatever_a_plugin_does_to_its_stderr() {
    for (name, define) in [
        ("null-stderr", "NULL_STDERR"),
        ("close-stderr", "CLOSE_STDERR"),
    ] {
        let (res, dir) = signalled(name, &[define], libc::SIGTERM, false);
        let err = &res.stderr;
        assert_eq!(res.status.signal(), Some(libc::SIGTERM), "{name}: {err}");
        assert!(
            err.contains("error: rwg received SIGTERM (a request to end"),
            "{name}: {err:?}"
        );
        assert!(err.contains("resume with: rwg run "), "{name}: {err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Every file under `dir` (recursively) whose bytes contain `needle`.
fn files_containing(dir: &Path, needle: &[u8]) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            found.extend(files_containing(&p, needle));
        } else if let Ok(b) = std::fs::read(&p) {
            if b.windows(needle.len()).any(|w| w == needle) {
                found.push(p);
            }
        }
    }
    found
}

/// A plugin that closes fds 1 and 2 and then prints in every step: the
/// files rwg opens next never take those descriptors (the plugin's prints
/// never land in, and its closes never close, rwg's results), and the run
/// completes and verifies.
#[test]
fn a_plugin_that_closes_its_stdio_cannot_reach_rwgs_files() {
    let (res, dir, _, out) = run_to_end("closed-stdio", &["CLOSE_STDERR"], 200);
    assert_eq!(res.status.code(), Some(0), "{}", res.stderr);
    let dirty = files_containing(&out, b"hostile: a line");
    assert!(dirty.is_empty(), "the plugin's prints landed in {dirty:?}");
    let verify = rwg(&["verify", path_str(&out)]);
    assert!(verify.status.success(), "{}", text(&verify.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `rwg run` of `samples` networks of a plugin built with `defines`, to its
/// end (at most 60 s): how it ended, the test's folder, the daemons' pid
/// folder and the run directory.
fn run_to_end(name: &str, defines: &[&str], samples: u32) -> (Ended, PathBuf, PathBuf, PathBuf) {
    let dir = temp_dir(&format!("procs-{name}"));
    let lib = hostile(name, defines);
    let m = study(&dir, &lib, samples);
    let pids = fresh(&dir, "pids");
    let out = dir.join("run");
    let args = ["run", &m, "--out", path_str(&out), "--no-report"];
    let child = rwg_cmd(&args, &pids).spawn().unwrap();
    let res = finish(child, &pids, Duration::from_secs(60), name);
    (res, dir, pids, out)
}

/// A plugin that calls `alarm(1)` (and installs no handler) ends rwg by
/// SIGALRM, named, with how to resume, and its daemons end with rwg.
#[test]
fn a_plugins_alarm_is_named() {
    let (res, dir, pids, _) = run_to_end(
        "alarm",
        &["ALARM_IN_CREATE", "SPAWN_DAEMONS", "SLEEP_IN_STEP_MS=1"],
        100_000,
    );
    let err = &res.stderr;
    assert_eq!(res.status.signal(), Some(libc::SIGALRM), "{err}");
    assert!(
        err.contains("error: rwg received SIGALRM (a timer's alarm, which rwg never sets: a plugin calling alarm() or setitimer()?); it ends. Every committed block is kept in"),
        "{err}"
    );
    all_ended("alarm", &pids);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plugin's exit handler that aborts once the run is complete: rwg says
/// so and that the results are whole (they verify), and the plugin's
/// daemons end with rwg.
#[test]
fn an_exit_handler_that_aborts_after_a_complete_run() {
    let (res, dir, pids, out) =
        run_to_end("abort-at-exit", &["ABORT_AT_EXIT", "SPAWN_DAEMONS"], 40);
    let err = &res.stderr;
    assert_eq!(res.status.signal(), Some(libc::SIGABRT), "{err}");
    assert!(
        err.contains(&format!(
            "error: rwg was killed by SIGABRT (abort) while exiting, after the command had \
             finished: in a plugin's exit handler or destructor? The run in {} is complete",
            out.display()
        )),
        "{err}"
    );
    all_ended("abort at exit", &pids);
    let verify = rwg(&["verify", path_str(&out)]);
    assert!(verify.status.success(), "{}", text(&verify.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plugin's error text holding terminal escape sequences (colour, window
/// title, clear screen) is shown escaped, by `rwg run` and `rwg check`.
#[test]
fn a_plugins_escape_sequences_are_shown_escaped() {
    let dir = temp_dir("procs-escapes");
    let lib = hostile("escapes", &["ESCAPES_IN_ERROR"]);
    let m = study(&dir, &lib, 8);
    let out = dir.join("run");
    let res = rwg(&["run", &m, "--out", path_str(&out), "--no-report"]);
    let err = text(&res.stderr);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(
        err.contains("reset failed with RWG_ERR_INTERNAL (6): \\x1b[31mred\\x1b[0m \\x1b]0;a new window title\\x07 \\x1b[2J cleared"),
        "{err}"
    );
    let check = rwg(&["check", path_str(&lib)]);
    for (what, bytes) in [
        ("run's stderr", &res.stderr),
        ("check's stdout", &check.stdout),
        ("check's stderr", &check.stderr),
    ] {
        assert!(
            !bytes.iter().any(|&b| b == 0x1b || b == 0x07),
            "{what} holds a raw escape sequence: {}",
            text(bytes)
        );
    }
    assert!(
        text(&check.stdout).contains("\\x1b[31mred"),
        "{}",
        text(&check.stdout)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
