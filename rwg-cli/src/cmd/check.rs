//! `rwg check`: the plugin conformance checks, each environment in a child
//! process, so that a plugin that crashes (segfault, abort) is reported as a
//! failed check instead of taking rwg down.
//!
//! The parent re-executes the current binary as `rwg __check-child PLUGIN`
//! (load the plugin, list its envs) and then `rwg __check-child PLUGIN --env
//! ID` per environment. The child writes one JSON object per line:
//! `{"loaded": ...}` or `{"load_error": ...}`; then `{"started": NAME}`
//! before each check, `{"result": CheckResult}` after it, and `{"done":
//! true}` at the end. A child that dies before `done` failed the check it had
//! started.

use anyhow::{bail, Context, Result};
use rwg_plugin_host::{
    check_plugin_env_observed, load_plugin, CheckEvent, CheckResult, CheckStatus,
};
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::Duration;

/// Arguments of `rwg check`.
#[derive(clap::Args)]
#[command(after_help = "\
Checks, after Gymnasium's env checker: instances can be created; the spaces are sane;
step before reset is refused; reset is deterministic and uses its seed; random
rollouts give finite rewards and observations inside the observation space; the same
seed and actions give the same trajectory, also with two instances interleaved or on
two threads (no hidden shared state); the time limit truncates; invalid actions are
refused; plus the ABI's own checks (id style, malformed raw actions, unseeded reset).

Each environment is checked in a child process: a plugin that crashes it is reported
as a failed check with the signal. Exits non-zero if any check failed.

Examples:
  rwg check target/release/librwg_example_plugin.so
  rwg check examples/plugin-c/libchain.so --env c_example/Chain-v0 --config length=20
  rwg check target/release/librwg_example_plugin.so --json > checks.json
  RWG_PLUGIN_PATH=examples/plugin-c rwg check c_example/Chain-v0 --config length=20
  rwg check gymnasium:CartPole-v1
  rwg check gymnasium:LunarLander-v3 --kwargs '{\"continuous\": true}'

A gymnasium:ID (or gymnasium:module:ID) is checked through the bridge: every
instance is a Python worker process of its own, so the same checks apply,
determinism included (two reset(seed=s) give the same observation; the same
seed and actions give the same trajectory, also interleaved and on two threads).
A worker that does not answer within RWG_GYM_TIMEOUT seconds (default 60) counts
as hung.")]
pub struct Args {
    /// The plugin library (`.so`, `.dylib`, `.dll`), the id of a plugin env
    /// found on RWG_PLUGIN_PATH (only it is checked), or a gymnasium: env id.
    plugin: PathBuf,
    #[command(flatten)]
    gym: crate::gym::GymArgs,
    /// Check only this environment.
    #[arg(long, value_name = "ID")]
    env: Option<String>,
    /// The config string instances are created with.
    #[arg(long, default_value = "")]
    config: String,
    /// Print the results as a JSON array.
    #[arg(long)]
    json: bool,
    /// Seconds an environment's checks may take before they count as hung.
    #[arg(long, default_value_t = 300, value_name = "SECONDS")]
    timeout: u64,
}

/// Arguments of the hidden `rwg __check-child` (run by `rwg check`).
#[derive(clap::Args)]
pub struct ChildArgs {
    /// The plugin library.
    plugin: PathBuf,
    /// The environment to check; without it, load the plugin and list its envs.
    #[arg(long)]
    env: Option<String>,
    /// The config string.
    #[arg(long, default_value = "")]
    config: String,
}

/// What the child reports after loading the plugin.
#[derive(Debug, Serialize, Deserialize)]
struct Loaded {
    id: String,
    version: String,
    abi: (u32, u32),
    envs: Vec<String>,
}

/// One line of the child's output.
#[derive(Debug, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Line {
    Loaded(Loaded),
    LoadError(String),
    Started(String),
    Result(CheckResult),
    Done(bool),
}

fn emit(out: &mut impl Write, line: &Line) {
    // The parent reads what was written before a crash: flush every line.
    let text = serde_json::to_string(line).expect("serialisable");
    let _ = writeln!(out, "{text}").and_then(|_| out.flush());
}

/// The checks whose failure `rwg run` warns about: results that depend on
/// more than the seed and actions (hidden state shared between instances or
/// threads).
const CONTRACT_CHECKS: [&str; 4] = [
    "reset determinism",
    "trajectory determinism",
    "independent instances",
    "threads",
];

/// How long `rwg run` lets the checks of one env take.
const CONTRACT_CHECK_TIMEOUT: Duration = Duration::from_secs(120);

/// Runs `rwg check`'s checks of one plugin env in a child process and returns
/// a warning for each failed determinism or thread-safety check (what `rwg
/// run` prints: such an env gives results that depend on the thread count).
/// None for an env whose rollouts fail outright (a crash, a panic, a NaN):
/// the run stops on that with its own error.
pub fn contract_warnings(plugin: &Path, env: &str, config: &str) -> Vec<String> {
    let args = [
        plugin.as_os_str(),
        "--env".as_ref(),
        env.as_ref(),
        "--config".as_ref(),
        config.as_ref(),
    ];
    let Ok(run) = spawn_child(&args, CONTRACT_CHECK_TIMEOUT) else {
        return vec![];
    };
    // An env that fails its plain rollouts fails the determinism checks for
    // that reason, not for hidden state; the run reports that failure itself.
    let rollout_fails = run.lines.iter().any(
        |l| matches!(l, Line::Result(r) if r.name == "rollout" && r.status == CheckStatus::Failed),
    );
    if rollout_fails {
        return vec![];
    }
    run.lines
        .into_iter()
        .filter_map(|l| match l {
            Line::Result(r)
                if r.status == CheckStatus::Failed
                    && CONTRACT_CHECKS.contains(&r.name.as_str()) =>
            {
                Some(format!(
                    "{} ({}) fails rwg check's '{}' check: {}; its results may depend on the \
                     thread count and on the other envs of the run (run `rwg check {}`)",
                    env,
                    plugin.display(),
                    r.name,
                    r.message,
                    rwg_study::shell::sh_path(plugin)
                ))
            }
            _ => None,
        })
        .collect()
}

/// Runs `rwg __check-child`.
pub fn run_child(args: ChildArgs) -> Result<()> {
    // Linux: end with the process that asked for the checks (`rwg run` may
    // finish or die first).
    #[cfg(target_os = "linux")]
    // SAFETY: prctl with a valid option and signal.
    unsafe {
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
    }
    let stdout = crate::stdio::stdout();
    let mut out = stdout.lock();
    let plugin = match load_plugin(&args.plugin) {
        Ok(p) => p,
        Err(e) => {
            emit(&mut out, &Line::LoadError(e.to_string()));
            return Ok(());
        }
    };
    let Some(id) = args.env else {
        let info = plugin.info();
        emit(
            &mut out,
            &Line::Loaded(Loaded {
                id: info.id.clone(),
                version: info.version.clone(),
                abi: info.abi,
                envs: plugin.envs().iter().map(|e| e.id().to_string()).collect(),
            }),
        );
        return Ok(());
    };
    let ty = plugin
        .env(&id)
        .with_context(|| format!("plugin '{}' has no environment '{id}'", plugin.id()))?;
    check_plugin_env_observed(ty, &args.config, &mut |ev| match ev {
        CheckEvent::Started { name, .. } => emit(&mut out, &Line::Started(name.to_string())),
        CheckEvent::Finished(r) => emit(&mut out, &Line::Result(r.clone())),
    });
    emit(&mut out, &Line::Done(true));
    Ok(())
}

/// How a child process ended.
struct ChildRun {
    lines: Vec<Line>,
    stderr: String,
    /// `None`: killed after the timeout.
    status: Option<ExitStatus>,
}

/// Runs `rwg __check-child` with `args`, killing it after `timeout`.
fn spawn_child(args: &[&std::ffi::OsStr], timeout: Duration) -> Result<ChildRun> {
    let exe = std::env::current_exe().context("cannot find the rwg executable")?;
    let mut cmd = Command::new(&exe);
    cmd.arg("__check-child")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // A member of rwg's family: a check that hangs dies with rwg (`rwg run`
    // that ends early, e.g. on an isolated plugin's crash, does not wait for
    // its background checks), and what the plugin started in it (a daemon
    // holding its pipes) ends with it.
    let mut child = rwg_worker::family::FamilyChild::spawn(cmd)
        .with_context(|| format!("cannot run {}", exe.display()))?;
    let drain = |mut r: Box<dyn Read + Send>| {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            let _ = r.read_to_end(&mut buf);
            let _ = tx.send(String::from_utf8_lossy(&buf).into_owned());
        });
        rx
    };
    let pipes = child.child_mut();
    let out = drain(Box::new(pipes.stdout.take().expect("piped")));
    let err = drain(Box::new(pipes.stderr.take().expect("piped")));
    let status = child.wait_timeout(timeout)?;
    // Its pipes close once it and what it started are gone; a process that
    // escaped the family (left its group and cleared its environment) may
    // hold them open: what was read by then is what is reported.
    let collect = |rx: std::sync::mpsc::Receiver<String>| {
        rx.recv_timeout(Duration::from_secs(2)).unwrap_or_default()
    };
    let stdout = collect(out);
    let stderr = collect(err);
    // A line cut short by a crash is dropped.
    let lines = stdout
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    Ok(ChildRun {
        lines,
        stderr,
        status,
    })
}

/// How a child ended, to follow "the checking process": "was killed by
/// signal 11 (SIGSEGV)", "exited with status 3", ...
fn describe_exit(status: Option<ExitStatus>, timeout: Duration) -> String {
    let Some(status) = status else {
        return format!(
            "did not finish within {} s (hung?) and was killed",
            timeout.as_secs()
        );
    };
    rwg_gym::describe_status(status)
}

/// The last few lines of a child's stderr, for a crash report.
fn stderr_tail(stderr: &str) -> String {
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let tail = &lines[lines.len().saturating_sub(3)..];
    if tail.is_empty() {
        String::new()
    } else {
        format!("; its stderr ended with: {}", tail.join(" | "))
    }
}

/// `rwg check gymnasium:ID`: the environment checks through the bridge.
fn run_gym(args: &Args, id: &str) -> Result<()> {
    let cfg = args.gym.config(id)?;
    let mut results = rwg_plugin_host::check::check_env(|| rwg_gym::make_single(&cfg));
    for r in &mut results {
        // The plugin contract asks envs to refuse invalid actions; Gymnasium
        // leaves that to each env (many clip), and rwg's networks only ever
        // produce valid ones: a warning, not a failure.
        if r.name == "invalid actions" && r.status == CheckStatus::Failed {
            r.status = CheckStatus::Warned;
            r.message
                .push_str(" (legal for a Gymnasium env; rwg's networks never produce them)");
        }
    }
    let mut kept = crate::details::KeptFile::new("check");
    for r in &results {
        if !args.json {
            writeln!(crate::stdio::stdout(), "{}", kept.one_line(&r.to_string()))?;
        }
    }
    finish(args, &results)
}

/// `rwg check ID` for a plugin env found on `RWG_PLUGIN_PATH`, as `rwg
/// rollout ID` finds it: the library that provides it, checking that env
/// only. A path that names no file and looks like a library is left as it
/// is (the load check reports it); a manifest given by mistake is refused
/// with what to run instead.
fn resolve_env_id(args: &mut Args) -> Result<()> {
    let library = |p: &Path| {
        p.extension()
            .is_some_and(|e| e == "so" || e == "dylib" || e == "dll")
    };
    if args.plugin.extension().is_some_and(|e| e == "toml") && args.plugin.is_file() {
        let (m, q) = (
            args.plugin.display(),
            rwg_study::shell::sh_path(&args.plugin),
        );
        bail!(
            "{m} is a manifest, not a plugin: `rwg run {q}` runs its study (add \
             `--samples 8 --episodes 2` for a quick try); rwg check takes a plugin library \
             file (.so, .dylib, .dll), the id of a plugin env on RWG_PLUGIN_PATH, or a \
             gymnasium: env id"
        );
    }
    if args.plugin.exists() || library(&args.plugin) {
        return Ok(());
    }
    let Some(id) = args.plugin.to_str().map(str::to_string) else {
        return Ok(());
    };
    use rwg_study::env_source::{Found, Plugins};
    match Plugins::default().find(&id) {
        Found::OnPath(ty) => {
            if let Some(other) = args.env.as_ref().filter(|e| **e != id) {
                bail!("rwg check {id} checks {id}; --env {other} names another env");
            }
            args.plugin = ty.plugin().path.clone();
            args.env = Some(id);
            Ok(())
        }
        Found::Builtin => bail!(
            "{id} is a built-in environment: rwg check checks a plugin's environments \
             (give its library, or the id of a plugin env on RWG_PLUGIN_PATH) or a \
             gymnasium: env"
        ),
        Found::Unknown(msg) => bail!(
            "{msg}; rwg check takes a plugin library file, the id of a plugin env on \
             RWG_PLUGIN_PATH, or a gymnasium: env id"
        ),
    }
}

/// Runs `rwg check`.
pub fn run(mut args: Args) -> Result<()> {
    if let Some(id) = args.plugin.to_str().filter(|s| crate::gym::is_gym(s)) {
        return run_gym(&args, id);
    }
    crate::gym::refuse_jax(&args.plugin.display().to_string(), "rwg check")?;
    args.gym.refuse_for(&args.plugin.display().to_string())?;
    resolve_env_id(&mut args)?;
    let timeout = Duration::from_secs(args.timeout.max(1));
    let mut results = Results {
        json: args.json,
        list: vec![],
        kept: crate::details::KeptFile::new("check"),
    };
    let Some(loaded) = load(&args, timeout, &mut results)? else {
        return finish(&args, &results.list);
    };
    report_builtin_ids(&loaded, &mut results)?;
    for id in envs_to_check(&args, &loaded)? {
        check_env(&args, id, timeout, &mut results)?;
    }
    finish(&args, &results.list)
}

/// The results of `rwg check` so far, each printed as it comes (without
/// `--json`).
struct Results {
    json: bool,
    list: Vec<CheckResult>,
    /// Where a check's traceback goes (its line names it).
    kept: crate::details::KeptFile,
}

impl Results {
    /// Prints `r` (writeln, not println: `rwg check ... | head` must not
    /// panic; one line, a traceback kept in a file it names) and keeps it.
    fn add(&mut self, r: CheckResult) -> std::io::Result<()> {
        if !self.json {
            writeln!(
                crate::stdio::stdout(),
                "{}",
                self.kept.one_line(&r.to_string())
            )?;
        }
        self.list.push(r);
        Ok(())
    }
}

/// The result of the `load` check.
fn load_result(status: CheckStatus, message: String) -> CheckResult {
    CheckResult {
        env: None,
        name: "load".into(),
        status,
        message,
    }
}

/// Loads the plugin in a checking process: what it holds, reported as the
/// `load` check; `None` if it does not load (the failure reported).
fn load(args: &Args, timeout: Duration, results: &mut Results) -> Result<Option<Loaded>> {
    let listing = spawn_child(&[args.plugin.as_os_str()], timeout)?;
    let loaded = listing.lines.into_iter().find_map(|l| match l {
        Line::Loaded(l) => Some(Ok(l)),
        Line::LoadError(e) => Some(Err(e)),
        _ => None,
    });
    let loaded = match loaded {
        Some(Ok(l)) if listing.status.is_some_and(|s| s.success()) => l,
        Some(Err(e)) => {
            results.add(load_result(CheckStatus::Failed, e))?;
            return Ok(None);
        }
        _ => {
            let msg = format!(
                "loading {}: the checking process {}{}",
                args.plugin.display(),
                describe_exit(listing.status, timeout),
                stderr_tail(&listing.stderr)
            );
            results.add(load_result(CheckStatus::Failed, msg))?;
            return Ok(None);
        }
    };
    results.add(load_result(
        CheckStatus::Passed,
        format!(
            "plugin '{}' {} (ABI {}.{}), {} environment(s)",
            loaded.id,
            loaded.version,
            loaded.abi.0,
            loaded.abi.1,
            loaded.envs.len()
        ),
    ))?;
    Ok(Some(loaded))
}

/// Fails every env of the plugin with a built-in id: such an id can never
/// be run from the plugin (RWG_PLUGIN_PATH skips the file and `plugin =` is
/// refused for it).
fn report_builtin_ids(loaded: &Loaded, results: &mut Results) -> Result<()> {
    for id in loaded
        .envs
        .iter()
        .filter(|id| rwg_study::env_source::is_builtin(id))
    {
        results.add(CheckResult {
            env: Some(id.clone()),
            name: "built-in id".into(),
            status: CheckStatus::Failed,
            message: format!(
                "'{id}' is the id of a built-in environment: rwg would never run this one \
                 (the built-in wins); give it a namespace, e.g. '{}/{id}'",
                loaded.id
            ),
        })?;
    }
    Ok(())
}

/// The envs to check: `--env`'s (refused if the plugin has no such env),
/// else all of them.
fn envs_to_check<'a>(args: &Args, loaded: &'a Loaded) -> Result<Vec<&'a String>> {
    Ok(match &args.env {
        None => loaded.envs.iter().collect(),
        Some(id) => match loaded.envs.iter().find(|e| *e == id) {
            Some(e) => vec![e],
            None => bail!(
                "plugin '{}' has no environment '{id}'; its environments: {}",
                loaded.id,
                loaded.envs.join(", ")
            ),
        },
    })
}

/// Runs env `id`'s checks in a checking process and reports each; a
/// process that does not finish them is a failed check of its own.
fn check_env(args: &Args, id: &str, timeout: Duration, results: &mut Results) -> Result<()> {
    let run = spawn_child(
        &[
            args.plugin.as_os_str(),
            "--env".as_ref(),
            id.as_ref(),
            "--config".as_ref(),
            args.config.as_ref(),
        ],
        timeout,
    )?;
    let mut started: Option<String> = None;
    let mut done = false;
    for line in run.lines {
        match line {
            Line::Started(name) => started = Some(name),
            Line::Result(r) => {
                started = None;
                results.add(r)?;
            }
            Line::Done(_) => done = true,
            Line::Loaded(_) | Line::LoadError(_) => {}
        }
    }
    if !done || !run.status.is_some_and(|s| s.success()) {
        let during = match &started {
            Some(name) => format!("during the '{name}' check"),
            None => "between checks".into(),
        };
        results.add(CheckResult {
            env: Some(id.to_string()),
            name: started.unwrap_or_else(|| "process".into()),
            status: CheckStatus::Failed,
            message: format!(
                "the checking process {} {during}: the plugin would take rwg \
                 down with it{}",
                describe_exit(run.status, timeout),
                stderr_tail(&run.stderr)
            ),
        })?;
    }
    Ok(())
}

/// Prints the JSON or the summary; fails if any check failed.
fn finish(args: &Args, results: &[CheckResult]) -> Result<()> {
    let count = |s| results.iter().filter(|r| r.status == s).count();
    let failed = count(CheckStatus::Failed);
    if args.json {
        writeln!(
            crate::stdio::stdout(),
            "{}",
            serde_json::to_string_pretty(results)?
        )?;
    } else {
        writeln!(
            crate::stdio::stdout(),
            "\n{}: {} passed, {} warned, {failed} failed",
            args.plugin.display(),
            count(CheckStatus::Passed),
            count(CheckStatus::Warned)
        )?;
    }
    if failed > 0 {
        bail!("{failed} check(s) failed for {}", args.plugin.display());
    }
    Ok(())
}
