//! Helpers shared by the end-to-end tests: run the real `rwg` binary.

#![allow(dead_code, reason = "each test file uses part of these helpers")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Path of the `rwg` binary built for these tests.
pub fn rwg_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_rwg"))
}

/// Runs `rwg` with `args`; returns its output.
pub fn rwg(args: &[&str]) -> Output {
    Command::new(rwg_bin())
        .args(args)
        .output()
        .expect("cannot run rwg")
}

/// Runs `rwg`, requires success, returns stdout.
pub fn rwg_ok(args: &[&str]) -> String {
    let out = rwg(args);
    assert!(
        out.status.success(),
        "rwg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `rwg`, requires failure, returns stderr.
pub fn rwg_err(args: &[&str]) -> String {
    let out = rwg(args);
    assert!(!out.status.success(), "rwg {args:?} should have failed");
    String::from_utf8(out.stderr).unwrap()
}

/// The workspace's `tests/data` directory (copies of the golden trajectories).
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data")
}

/// A fresh directory for one test, under Cargo's `target/tmp`: emptied when
/// the same test starts again (so runs do not pile up in the system's temp
/// folder) and left after it, to look at, until then or `cargo clean`.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("rwg-test-{}-{name}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes a synthetic run (CartPole-like and Pendulum-like cells, each
/// architecture with and without bias) into a fresh directory.
pub fn synthetic_run(name: &str, samples: u64, episodes: u32) -> PathBuf {
    use rwg_study::rundir::data::synthetic::{write_synthetic_run, SyntheticCell, SyntheticRun};
    let dir = temp_dir(name);
    let mut cells = Vec::new();
    for bias in [false, true] {
        cells.push(SyntheticCell::cartpole("0HL", &[], bias));
        cells.push(SyntheticCell::cartpole("1HL-4", &[4], bias));
        cells.push(SyntheticCell::pendulum("0HL", &[], bias));
        cells.push(SyntheticCell::pendulum("1HL-4", &[4], bias));
    }
    write_synthetic_run(
        &dir,
        &SyntheticRun {
            samples,
            episodes,
            seed: 3,
            cells,
        },
    )
    .unwrap();
    dir
}

/// `<target>/<profile>/deps`, where the test binaries (and the plugin
/// cdylibs cargo builds for rwg-cli's dev-dependencies) are.
pub fn deps_dir() -> PathBuf {
    std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The Rust plugin library `name` (e.g. `rwg_plugin_classic_control`), built
/// by cargo because the plugin packages are dev-dependencies of rwg-cli.
pub fn rust_plugin(name: &str) -> PathBuf {
    let deps = deps_dir();
    let file = rwg_plugin_host::library_file_name(name);
    [deps.clone(), deps.parent().unwrap().to_path_buf()]
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{file} not found near {}", deps.display()))
}

/// The reference plugin (the built-ins as `classic_control/<id>`).
pub fn classic_control_plugin() -> PathBuf {
    rust_plugin("rwg_plugin_classic_control")
}

/// The deliberately broken plugins (`broken/<fault>-v0`).
pub fn broken_plugin() -> PathBuf {
    rust_plugin("rwg_testing_plugins")
}

/// Compiles the C file `src` (relative to the repository root) into
/// `lib<name>.so` in a folder for `test`, with `-D` defines and warnings as
/// errors, using `$CC` or `cc`. The library is written under a name of its
/// own and renamed into place, so a test loading it while another test of
/// the same binary compiles it again never sees a half-written file.
pub fn compile_c(test: &str, src: &str, name: &str, defines: &[&str]) -> PathBuf {
    static BUILDS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = deps_dir()
        .parent()
        .unwrap()
        .join("rwg-c-plugins")
        .join(format!("cli-{test}"));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join(rwg_plugin_host::library_file_name(name));
    let build = BUILDS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}-{}-{build}.so.tmp", std::process::id()));
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
        .args(["-shared", "-fPIC", "-fvisibility=hidden"])
        .arg("-I")
        .arg(root.join("rwg-env/include"))
        .args(defines.iter().map(|d| format!("-D{d}")))
        .arg(root.join(src))
        .arg("-o")
        .arg(&tmp)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler '{cc}': {e}"));
    assert!(
        res.status.success(),
        "compiling {src} failed:\n{}",
        String::from_utf8_lossy(&res.stderr)
    );
    std::fs::rename(&tmp, &out).unwrap();
    out
}

/// Runs `rwg` with `args` and environment variables `vars`;
/// `RWG_PLUGIN_PATH` is unset unless `vars` sets it.
pub fn rwg_env(args: &[&str], vars: &[(&str, &std::ffi::OsStr)]) -> Output {
    let mut cmd = Command::new(rwg_bin());
    cmd.args(args).env_remove("RWG_PLUGIN_PATH");
    for (k, v) in vars {
        cmd.env(k, v);
    }
    cmd.output().expect("cannot run rwg")
}

/// `err` with the files its `error:` lines name as keeping their long part
/// (`...; the Python traceback is in FILE`) appended: what a user reads
/// who opens the file.
pub fn with_details(err: &str) -> String {
    let mut all = err.to_string();
    for line in err.lines().filter(|l| l.starts_with("error: ")) {
        if let Some((_, path)) = line.rsplit_once(" is in ") {
            if let Ok(text) = std::fs::read_to_string(path.trim_end()) {
                all.push('\n');
                all.push_str(&text);
            }
        }
    }
    all
}

/// Whether a skipped test must fail instead: under CI (`CI=true`) or with
/// `RWG_NO_SKIP=1`.
pub fn skips_forbidden() -> bool {
    std::env::var("CI").as_deref() == Ok("true")
        || std::env::var("RWG_NO_SKIP").as_deref() == Ok("1")
}

/// Marks `test` as not run because `why`: prints `SKIPPED <test>: <why>` to
/// the process's stderr (past the test harness's capture, so it shows in
/// `cargo test`'s output), or panics when [`skips_forbidden`].
pub fn skip(test: &str, why: &str) {
    assert!(
        !skips_forbidden(),
        "{test} cannot run and skips are not allowed here (CI=true or RWG_NO_SKIP=1): {why}"
    );
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: {why}");
}

/// A headless Chromium-family browser on PATH (or `RWG_CHROMIUM`).
pub fn browser() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("RWG_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for name in ["chromium", "chromium-browser", "google-chrome", "chrome"] {
        for d in std::env::split_paths(&path) {
            let p = d.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// Runs the browser headless on `page` with `extra` flags and a fresh
/// profile in `profile`; returns stdout. Fails after 120 s.
pub fn headless(browser: &Path, page: &Path, extra: &[&str], profile: &Path) -> String {
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("cannot start the browser");
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(stdout).unwrap_or_default());
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the browser did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    reader.join().unwrap()
}

/// The numeric attribute `data-<name>` of `<body>` in a dumped DOM.
pub fn body_attr(dom: &str, name: &str) -> Option<usize> {
    let body = &dom[dom.find("<body")?..];
    let body = &body[..body.find('>')?];
    let key = format!("data-{name}=\"");
    let v = &body[body.find(&key)? + key.len()..];
    v[..v.find('"')?].parse().ok()
}

/// Loads `page` in headless Chromium in a 1280 px wide window and checks
/// what a reader would see: `figures` figures, every one rendered, no script
/// or console error, no horizontal scrolling. Returns the dumped DOM.
pub fn check_page_in_browser(
    browser: &Path,
    page: &Path,
    figures: usize,
    profile: &Path,
) -> String {
    let dom = headless(
        browser,
        page,
        &["--window-size=1280,900", "--dump-dom"],
        profile,
    );
    assert_eq!(
        body_attr(&dom, "figures"),
        Some(figures),
        "figures counted by {}",
        page.display()
    );
    assert_eq!(
        body_attr(&dom, "rendered"),
        Some(figures),
        "figures rendered in {}",
        page.display()
    );
    assert_eq!(dom.matches("data-rendered=\"ok\"").count(), figures);
    assert_eq!(
        body_attr(&dom, "errors"),
        Some(0),
        "script or console errors in {}",
        page.display()
    );
    let (scroll, view) = (
        body_attr(&dom, "scroll-width").expect("scroll width reported"),
        body_attr(&dom, "viewport-width").expect("viewport width reported"),
    );
    assert_eq!(view, 1280, "the window is 1280 px wide");
    assert!(
        scroll <= view,
        "{} scrolls sideways at 1280 px: {scroll} px wide",
        page.display()
    );
    dom
}

/// Ctrl-C on a terminal once `file` exists: starts `cmd` (an `rwg run`) in
/// a process group of its own with piped output, waits (up to `wait`) until
/// `file` exists, sends SIGINT to the whole group (rwg and any worker
/// processes, as a terminal does) and returns rwg's output once it ends.
#[cfg(unix)]
pub fn ctrl_c_when(mut cmd: Command, file: &Path, wait: std::time::Duration) -> Output {
    use std::os::unix::process::CommandExt;
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let child = cmd
        .process_group(0)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !file.exists() && t0.elapsed() < wait {
        std::thread::sleep(Duration::from_millis(20));
    }
    let group = format!("-{}", child.id());
    let kill = Command::new("kill")
        .args(["-INT", "--", &group])
        .status()
        .unwrap();
    assert!(kill.success());
    child.wait_with_output().unwrap()
}

/// Ctrl-C on a terminal, after the run's first block ([`ctrl_c_when`]
/// `blocks/b0000000.csv` exists, waiting up to 60 s), and checks what every
/// interrupted run must show: exit status 130, the message that the finished
/// blocks are saved, and the first block still there. Returns rwg's stderr.
#[cfg(unix)]
pub fn ctrl_c_after_first_block(cmd: Command, blocks: &Path) -> String {
    let first = blocks.join("b0000000.csv");
    let res = ctrl_c_when(cmd, &first, std::time::Duration::from_secs(60));
    let err = String::from_utf8_lossy(&res.stderr).into_owned();
    assert_eq!(res.status.code(), Some(130), "{err}");
    assert!(
        err.contains("stopped; every finished block is saved in"),
        "{err}"
    );
    assert!(first.is_file(), "{err}");
    err
}

/// Rewrites the digest of `name` in the `SHA256SUMS` of `dir` to the file's
/// digest now: what a hand edit that "fixes" the index leaves.
pub fn reindex(dir: &Path, name: &str) {
    use rwg_study::rundir::checksum::{hash_file, hex};
    let sums = dir.join("SHA256SUMS");
    let d = hex(&hash_file(&dir.join(name)).unwrap());
    let text: String = std::fs::read_to_string(&sums)
        .unwrap()
        .lines()
        .map(|l| match l.split_once("  ") {
            Some((_, n)) if n == name => format!("{d}  {n}\n"),
            _ => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&sums, text).unwrap();
}

/// A small tmpfs mounted for one test, unmounted when dropped.
pub struct SmallDisk(pub PathBuf);

impl SmallDisk {
    /// A tmpfs of `size` (mount's `size=`) at a fresh folder; `Err` with the
    /// reason where mounting is not allowed (not root, no mount(8)).
    pub fn mount(name: &str, size: &str) -> Result<SmallDisk, String> {
        let dir = temp_dir(name).join("disk");
        std::fs::create_dir_all(&dir).unwrap();
        let out = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&dir)
            .output()
            .map_err(|e| format!("cannot run mount: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "cannot mount a tmpfs (needs root): {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Ok(SmallDisk(dir))
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(&self.0).status();
    }
}

/// Whether `shown` (a number as a page prints it: `-76.10`, `1.92e-5`,
/// `2,858`) is `value` rounded to the digits `shown` has.
pub fn shows(shown: &str, value: f64) -> bool {
    let shown = shown.replace(',', "");
    let (mantissa, exp) = match shown.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().unwrap()),
        None => (&shown[..], 0),
    };
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    let unit = 10f64.powi(exp - decimals);
    let v: f64 = shown.parse().unwrap();
    (v - value).abs() <= 0.5 * unit * (1.0 + 1e-9) + 1e-12
}

/// The process ids of `pid`'s children.
#[cfg(target_os = "linux")]
pub fn children(pid: u32) -> Vec<u32> {
    let mut out = vec![];
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(child) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        // pid (comm) state ppid ...
        let rest = &stat[stat.rfind(')').unwrap() + 2..];
        if rest.split_whitespace().nth(1) == Some(&pid.to_string()) {
            out.push(child);
        }
    }
    out
}

/// Whether process `pid` is running (not gone, not a zombie).
#[cfg(target_os = "linux")]
pub fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(stat) => !matches!(
            stat[stat.rfind(')').unwrap() + 2..].chars().next(),
            Some('Z' | 'X')
        ),
        Err(_) => false,
    }
}

/// A small study: two CartPole-v1 cells of 3 blocks each, a fraction of a
/// second in a debug build.
pub const SMALL_STUDY: &str = r#"
seed = 5
samples = 70
episodes = 3
bias = [false]
[[architectures]]
name = "0HL"
hidden = []
[[architectures]]
name = "1HL"
hidden = [3]
[[envs]]
id = "CartPole-v1"
"#;

/// A path as the `&str` the helpers take (test paths are UTF-8).
pub fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Writes `body` as `dir/name`; returns its path.
pub fn write_manifest(dir: &Path, name: &str, body: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p
}

/// A finished run of the study `body` in `dir/name` (its manifest beside it,
/// `name.toml`), without report.
pub fn finished_run(dir: &Path, name: &str, body: &str) -> PathBuf {
    let m = write_manifest(dir, &format!("{name}.toml"), body);
    let out = dir.join(name);
    rwg_ok(&["run", path_str(&m), "--out", path_str(&out), "--no-report"]);
    out
}

/// A command's stdout, then its stderr, as text.
pub fn output_text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Runs `rwg`, requires failure, returns its stdout and stderr (a reader
/// such as `rwg verify` names problems on stdout).
pub fn rwg_fails(args: &[&str]) -> String {
    let out = rwg(args);
    let text = output_text(&out);
    assert!(
        !out.status.success(),
        "rwg {args:?} should have failed:\n{text}"
    );
    text
}

/// Runs `mount` with `args`; `Err` with why not (not root, no mount(8)).
pub fn mount(args: &[&str]) -> Result<(), String> {
    let o = Command::new("mount")
        .args(args)
        .output()
        .map_err(|e| e.to_string())?;
    o.status
        .success()
        .then_some(())
        .ok_or_else(|| String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A mount at a folder, unmounted when dropped.
pub struct Mounted(pub PathBuf);

impl Mounted {
    /// A read-only bind mount of `src` at `at` (created if needed).
    pub fn read_only(src: &Path, at: &Path) -> Result<Mounted, String> {
        std::fs::create_dir_all(at).unwrap();
        mount(&["--bind", path_str(src), path_str(at)])?;
        let m = Mounted(at.to_path_buf());
        mount(&["-o", "remount,ro,bind", path_str(at)])?;
        Ok(m)
    }
}

impl Drop for Mounted {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// Makes `cmd` start with the signals a test sends rwg at their default
/// action, whatever the test inherited: under `nohup` or as a shell's
/// background job SIGHUP, SIGINT or SIGQUIT arrive ignored, and rwg rightly
/// leaves an ignored signal ignored.
#[cfg(unix)]
pub fn with_default_signals(cmd: &mut Command) -> &mut Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: signal(2) is async-signal-safe, the only call between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            for s in [
                libc::SIGHUP,
                libc::SIGINT,
                libc::SIGQUIT,
                libc::SIGTERM,
                libc::SIGUSR2,
            ] {
                libc::signal(s, libc::SIG_DFL);
            }
            Ok(())
        })
    }
}
