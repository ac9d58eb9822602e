//! Process resource limits: a file-size limit (`ulimit -f`) is an I/O error
//! naming the file, status 1, and the run resumes once the limit is raised;
//! an address-space limit (`ulimit -v`) that leaves no room to start a thread
//! or to allocate is a resource error naming it, status 1 — never a silent
//! SIGXFSZ, "internal error (a bug in rwg)" or an abort; an open-file limit
//! (`ulimit -n`) that refuses a worker's pipes is named with what to do.

#![cfg(target_os = "linux")]

mod common;
use common::*;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::process::{Command, Output};

/// `rwg ARGS` with the soft and hard limit `resource` set to `value`.
fn limited(args: &[&str], resource: libc::__rlimit_resource_t, value: u64) -> Output {
    let mut c = Command::new(rwg_bin());
    c.args(args).env_remove("RWG_PLUGIN_PATH");
    // SAFETY: setrlimit is async-signal-safe, the only call between fork and exec.
    unsafe {
        c.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: value,
                rlim_max: value,
            };
            if libc::setrlimit(resource, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            // what `ulimit -f` does in a shell: SIGXFSZ at its default action
            libc::signal(libc::SIGXFSZ, libc::SIG_DFL);
            Ok(())
        });
    }
    c.output().unwrap()
}

const STUDY: &str = "seed = 5\nsamples = 3000\nepisodes = 5\n[[architectures]]\nname = \
                     \"0HL\"\nhidden = []\n[[envs]]\nid = \"CartPole-v1\"\n";

/// scores.csv outgrows a 64 KiB file-size limit: rwg reports the file and
/// the limit (status 1, not killed by SIGXFSZ); the same command, the limit
/// lifted, resumes and finishes a run that verifies.
#[test]
fn a_file_size_limit_is_an_error_naming_the_file() {
    let dir = temp_dir("resources-fsize");
    let m = write_manifest(&dir, "m.toml", STUDY);
    let out = dir.join("run");
    let args = ["run", path_str(&m), "--out", path_str(&out), "-q"];
    let res = limited(&args, libc::RLIMIT_FSIZE, 64 * 1024);
    let err = output_text(&res);
    assert_eq!(res.status.signal(), None, "killed by a signal: {err}");
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(
        err.contains("scores.csv: File too large (os error 27)"),
        "{err}"
    );
    assert!(
        err.contains("hint: files are limited to 65536 bytes in this shell (`ulimit -f`"),
        "{err}"
    );
    let again = rwg(&args);
    assert!(again.status.success(), "{}", output_text(&again));
    let verify = rwg(&["verify", path_str(&out)]);
    assert!(verify.status.success(), "{}", output_text(&verify));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Address-space limits from too small to start rwg's threads up to
/// enough: every run either finishes or fails with status 1 and a resource
/// error — for some limit, a thread that cannot start — never a panic's
/// "internal error", status 101, or an abort. Limits under which even
/// `rwg --version` cannot start are skipped.
#[test]
fn an_address_space_limit_is_a_resource_error() {
    let dir = temp_dir("resources-as");
    let m = write_manifest(
        &dir,
        "m.toml",
        &STUDY.replace("samples = 3000", "samples = 64"),
    );
    let mut thread_errors = 0;
    let mut finished = 0;
    for mib in (24..=96).step_by(6) {
        let out = dir.join(format!("run-{mib}"));
        let args = [
            "run",
            path_str(&m),
            "--out",
            path_str(&out),
            "-q",
            "--no-report",
            "--threads",
            "2",
        ];
        // too small for the process to start at all (the dynamic loader, or
        // the runtime before main, fails): no command of rwg runs there
        if !limited(&["--version"], libc::RLIMIT_AS, mib << 20)
            .status
            .success()
        {
            continue;
        }
        let res = limited(&args, libc::RLIMIT_AS, mib << 20);
        let err = output_text(&res);
        assert_eq!(res.status.signal(), None, "{mib} MiB: killed: {err}");
        assert!(!err.contains("internal error"), "{mib} MiB: {err}");
        if res.status.success() {
            finished += 1;
            continue;
        }
        assert_eq!(res.status.code(), Some(1), "{mib} MiB: {err}");
        let thread = err.contains("error: cannot start a thread: ")
            || err.contains("error: cannot start 2 worker threads: ")
            || err.contains("error: cannot start the report's threads");
        let memory = err.contains("error: rwg ran out of memory: an allocation of ");
        assert!(thread || memory, "{mib} MiB: {err}");
        assert!(
            err.contains("raise the limit, or run with fewer --threads"),
            "{mib} MiB: {err}"
        );
        thread_errors += usize::from(thread);
    }
    assert!(thread_errors > 0, "no limit kept a thread from starting");
    assert!(finished > 0, "no limit let the run finish");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An isolated plugin whose worker's pipes the open-file limit refuses: the
/// error says so, gives the limit and what to do (status 1).
#[test]
fn an_open_file_limit_is_named_with_what_to_do() {
    let dir = temp_dir("resources-nofile");
    let lib = compile_c(
        "resources-nofile",
        "plugins/testing/c/hostile.c",
        "hostile",
        &[],
    );
    let m = write_manifest(
        &dir,
        "m.toml",
        &format!(
            "samples = 8\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden =              []\n[[envs]]\nid = \"hostile/Counter-v0\"\nplugin = {:?}\n",
            path_str(&lib)
        ),
    );
    let out = dir.join("run");
    let args = [
        "run",
        path_str(&m),
        "--out",
        path_str(&out),
        "--isolate",
        "-q",
    ];
    let res = limited(&args, libc::RLIMIT_NOFILE, 12);
    let err = output_text(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(err.contains("Too many open files (os error 24)"), "{err}");
    assert!(
        err.contains("hint: a process may have 12 files open at once here (`ulimit -n`;"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
