//! Works as printed: every command in the ```sh blocks of the README and of
//! every Markdown page under `docs/`, and in every `rwg <command> --help`
//! Examples section, runs in the order shown. Each page runs in a scratch
//! folder of its own laid out as a reader's clone of the repository (the
//! `examples/` folder, the peer scripts of `benches/peers/`, the plugin
//! header and the committed runs of `docs/paper-blocks/`), with `rwg` on PATH and the release artefacts the pages build
//! under `target/release/`; the `--help` examples run after the README's, in
//! its folder. Each must exit 0 with output of the expected shape. A command
//! is read as a reader's shell would: a `# comment` dropped, `\` lines
//! joined, a here-document (`cat > f <<'EOF'` ... `EOF`) kept whole.
//!
//! What the test does instead of running a command as printed (each is
//! printed to the test output when it applies, never silently):
//! - `cargo install --path rwg-cli` and `cargo build --release ...`: the test
//!   provides what they make (`rwg` on PATH; `target/release/rwg` and the
//!   plugin libraries are the test build's, linked there).
//! - `cargo test --workspace`: not run, it is this test suite.
//! - The JAX atlas's commands (`examples/jax-atlas.toml`, docs/jax-families.md):
//!   not run here; tests/cli_jax_atlas.rs runs them on one env of the atlas.
//! - `pip install ...` and `maturin build`: not run; `.ci/run` builds the
//!   wheel with maturin and installs it into a fresh virtualenv.
//!   `cargo install --path rwg-cli --no-default-features`: not run, a
//!   release build of its own; `.ci/run` builds without default features.
//! - Studies are reduced: every `rwg run` gets `--samples 32 --episodes 4`
//!   (replacing a `--samples` it has; `examples/atlas.toml`, 45 cells mostly
//!   stepped in Python, `--samples 4 --episodes 1`), `plugin-overhead.sh` runs with
//!   `SAMPLES=32 EPISODES=2`, `examples/paper-runtime.py` with `--samples 8
//!   --repeats 1`, `rwg bench envs` with `--steps 20000`,
//!   `rwg bench sampler` and `rwg bench gym` with `--samples 16 --episodes 2`
//!   (and `--repeats 1`), `rwg bench plugin` with `--samples 16 --episodes 2
//!   --rounds 1`, `rwg bench libm` with `--check 20000 --rounds 1` (and
//!   `--pow-check 20000` for a `--pow-check` it has): the tests run a
//!   debug build, ten times slower than the release build the README uses,
//!   and the full paper study alone would take an hour. With 32 networks
//!   per cell, `rwg stats` and `rwg report` get `--at-n 8` for an `--at-n`
//!   they have (4 disjoint blocks of 8 networks).
//! - `rwg slurm` without `--dry-run` gets `--dry-run`: there is no Slurm
//!   cluster here (tests/cli_slurm.rs submits to a real one).
//! - `python3 -m pip install "gymnasium[...]"`: not run; the Python of
//!   `RWG_TEST_PYTHON` (the CI virtualenv, which holds those packages) is
//!   handed to rwg as `RWG_PYTHON`. Without it the examples that need it are
//!   skipped, visibly, and under `CI=true` the test fails: those that name a
//!   `gymnasium:` env or `rwg bench gym`, run a manifest with a
//!   `gymnasium:` env, or a Python script that imports numpy, pandas or
//!   Gymnasium (what a command needs is read from what it runs, [`needs`]).
//! - JAX (`python3 -m pip install jax gymnax`, a family's line): not run; a
//!   command that names JAX, gymnax, Brax or a JAX family (docs/jax.md,
//!   docs/jax-families.md, the `gymnax:` envs) runs with
//!   the Python of `RWG_PEER_PYTHON` (jax, gymnax, brax) as `RWG_PYTHON` and
//!   its folder on PATH after rwg's (`python3` is that Python); without it
//!   such a command is skipped, visibly, and under `CI=true` the test fails.
//! - The JAX peer's virtualenv, `rwg bench peers` (about 25 minutes) and the
//!   peer scripts run by hand (`benches/peers/*.py`, which need that
//!   virtualenv): not run; tests/cli_bench.rs runs `rwg bench peers` and
//!   `benches/peers/side_by_side.py` on tiny counts when `RWG_PEER_PYTHON`
//!   names a Python with the peer. `rwg bench gym --peer
//!   benches/peers/ref_numpy.py` runs (it needs gymnasium only).

#[path = "examples_support/command_needs.rs"]
mod command_needs;
mod common;
use command_needs::{needs, needs_jax, outputs};
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// One command shown to the reader.
#[derive(Debug, Clone)]
struct Example {
    /// Where it is shown: `PAGE:LINE` (`docs/guide.md:12`) or `rwg X --help`.
    source: String,
    /// The command as printed (comment removed, continuation lines joined).
    command: String,
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `line` without a trailing `# comment` (a `#` after whitespace, outside
/// quotes).
fn strip_comment(line: &str) -> &str {
    let (mut single, mut double) = (false, false);
    let b = line.as_bytes();
    for (i, &c) in b.iter().enumerate() {
        match c {
            b'\'' if !double => single = !single,
            b'"' if !single => double = !double,
            b'#' if !single && !double && (i == 0 || b[i - 1].is_ascii_whitespace()) => {
                return line[..i].trim_end();
            }
            _ => {}
        }
    }
    line.trim_end()
}

/// The pages whose ```sh blocks this test runs: the README, then every
/// Markdown page under `docs/` (sorted by path), as paths relative to the
/// repository.
fn doc_pages() -> Vec<String> {
    fn walk(dir: &Path, rel: &str, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let entry = entry.unwrap();
            let name = entry.file_name().into_string().unwrap();
            let rel = format!("{rel}/{name}");
            if entry.file_type().unwrap().is_dir() {
                walk(&entry.path(), &rel, out);
            } else if name.ends_with(".md") {
                out.push(rel);
            }
        }
    }
    let mut docs = Vec::new();
    walk(&repo().join("docs"), "docs", &mut docs);
    docs.sort();
    std::iter::once("README.md".to_string())
        .chain(docs)
        .collect()
}

/// The terminator of a here-document that `line` opens (`cmd <<'EOF'`,
/// `cmd <<EOF`), if it opens one.
fn heredoc_terminator(line: &str) -> Option<String> {
    let (_, tail) = line.rsplit_once("<<")?;
    let word = tail.trim().trim_start_matches('-');
    let word = word.trim_matches(|c| c == '\'' || c == '"');
    let ok = !word.is_empty() && word.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    ok.then(|| word.to_string())
}

/// The commands of the ```sh blocks of `page` (relative to the repository),
/// in order: comments removed, `\` continuations joined, a here-document
/// kept whole (its lines verbatim up to its terminator).
fn page_examples(page: &str) -> Vec<Example> {
    let text = std::fs::read_to_string(repo().join(page)).unwrap();
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut pending: Option<(usize, String)> = None;
    let mut heredoc: Option<(usize, String, String)> = None;
    for (i, line) in text.lines().enumerate() {
        if let Some((start, mut cmd, end)) = heredoc.take() {
            cmd.push('\n');
            cmd.push_str(line);
            if line.trim() == end {
                out.push(Example {
                    source: format!("{page}:{start}"),
                    command: cmd,
                });
            } else {
                heredoc = Some((start, cmd, end));
            }
            continue;
        }
        if line.starts_with("```") {
            // shell commands stand in ```sh blocks, which this test runs; one
            // in a block of another shell name would be skipped unseen
            let lang = line.trim().trim_start_matches('`');
            assert!(
                !["bash", "shell", "console", "zsh", "shell-session"].contains(&lang),
                "{page}:{}: a ```{lang} block: write ```sh, so that this test runs it",
                i + 1
            );
            in_sh = !in_sh && line.trim() == "```sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let (start, mut cmd) = pending.take().unwrap_or((i + 1, String::new()));
        let l = strip_comment(line);
        if let Some(cont) = l.strip_suffix('\\') {
            cmd.push_str(cont);
            pending = Some((start, cmd));
            continue;
        }
        cmd.push_str(l);
        let cmd = cmd.trim().to_string();
        if let Some(end) = heredoc_terminator(&cmd) {
            heredoc = Some((start, cmd, end));
            continue;
        }
        if !cmd.is_empty() {
            out.push(Example {
                source: format!("{page}:{start}"),
                command: cmd,
            });
        }
    }
    assert!(
        heredoc.is_none(),
        "{page}: a here-document runs to the end of the page"
    );
    out
}

/// Clap wraps help text at this width: an example longer than this would
/// be printed broken over two lines.
const HELP_WIDTH: usize = 100;

/// The commands of every `--help` Examples section, subcommands included.
fn help_examples() -> Vec<Example> {
    let commands = |help: &str| -> Vec<String> {
        help.lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            // a name stands at two spaces; deeper lines continue a wrapped description
            .filter(|l| !l.starts_with("   "))
            .filter_map(|l| l.split_whitespace().next().map(str::to_string))
            .filter(|c| c != "help")
            .collect()
    };
    // `rwg --help` itself, every command's and every subcommand's
    let mut paths: Vec<Vec<String>> = vec![vec![]];
    for c in commands(&rwg_ok(&["--help"])) {
        let sub = commands(&rwg_ok(&[&c, "--help"]));
        paths.push(vec![c.clone()]);
        paths.extend(sub.into_iter().map(|s| vec![c.clone(), s]));
    }
    let mut out = Vec::new();
    for p in paths {
        let mut args: Vec<&str> = p.iter().map(String::as_str).collect();
        args.push("--help");
        let help = rwg_ok(&args);
        let source = format!("rwg {}", args.join(" "));
        let mut in_examples = false;
        let mut pending: Option<String> = None;
        for l in help.lines() {
            if l.starts_with("Example") {
                assert!(l == "Example:" || l == "Examples:", "{l}");
                in_examples = true;
                continue;
            }
            if !l.starts_with("  ") {
                assert!(
                    pending.is_none(),
                    "`{source}`: an example ends in `\\` with no line after it"
                );
                in_examples = false;
                continue;
            }
            if !in_examples {
                // a command shown anywhere else would not be run: refuse it
                let shown = !l.starts_with("   ")
                    && ["rwg ", "python3 ", "target/", "make ", "cargo "]
                        .iter()
                        .any(|w| l.trim_start().starts_with(w));
                assert!(
                    !shown,
                    "`{source}` shows a command outside its Examples section, where this \
                     test would not run it: {l}"
                );
                continue;
            }
            assert!(
                l.chars().count() < HELP_WIDTH,
                "`{source}`: an example line of {} characters is wrapped by clap: {l}",
                l.chars().count()
            );
            let line = strip_comment(l.trim());
            let mut cmd = match pending.take() {
                // the continuation of a line that ended in `\`
                Some(head) => head + " " + line,
                None => {
                    // a command starts with rwg, a program of the set-up (python3,
                    // one in target/), an environment assignment or a loop;
                    // anything else is the tail of a line clap wrapped
                    let first = line.split_whitespace().next().unwrap_or("");
                    assert!(
                        ["rwg", "for", "python3"].contains(&first)
                            || first.starts_with("target/")
                            || first.contains('='),
                        "`{source}`: an example line that is no command (the tail of a \
                         wrapped line?): {l}"
                    );
                    line.to_string()
                }
            };
            if let Some(head) = cmd.strip_suffix('\\') {
                cmd = head.trim_end().to_string();
                pending = Some(cmd);
                continue;
            }
            out.push(Example {
                source: source.clone(),
                command: cmd,
            });
        }
        assert!(
            pending.is_none(),
            "`{source}`: an example ends in `\\` with no line after it"
        );
    }
    out
}

/// The scratch folder: a reader's clone as far as the examples need it.
fn prepare(dir: &Path) -> PathBuf {
    let copy = |rel: &str| {
        let status = Command::new("cp")
            .arg("-r")
            .arg(repo().join(rel))
            .arg(dir.join(rel).parent().unwrap())
            .status()
            .unwrap();
        assert!(status.success(), "cannot copy {rel}");
    };
    std::fs::create_dir_all(dir.join("rwg-env")).unwrap();
    copy("examples");
    copy("benches");
    std::fs::create_dir_all(dir.join("docs")).unwrap();
    copy("docs/paper-blocks");
    copy("rwg-env/include");
    // built by make in the repository, maybe: the reader's clone has none
    for f in ["libchain.so", "libchain.dylib"] {
        let _ = std::fs::remove_file(dir.join("examples/plugin-c").join(f));
    }
    // what `cargo install --path rwg-cli` and `cargo build --release` make
    let release = dir.join("target/release");
    std::fs::create_dir_all(&release).unwrap();
    let link = |from: &Path, to: &Path| std::os::unix::fs::symlink(from, to).unwrap();
    link(&rwg_bin(), &release.join("rwg"));
    for lib in ["rwg_example_plugin", "rwg_plugin_classic_control"] {
        link(
            &rust_plugin(lib),
            &release.join(rwg_plugin_host::library_file_name(lib)),
        );
    }
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    link(&rwg_bin(), &bin.join("rwg"));
    std::fs::create_dir_all(dir.join("home")).unwrap();
    bin
}

/// What the test runs for an example, or why it runs nothing.
enum Plan {
    Run(String),
    NotRun(&'static str),
}

/// Replaces `--flag VALUE` in `cmd` by `--flag value`, or appends it.
fn set_flag(cmd: &str, flag: &str, value: &str) -> String {
    let words: Vec<&str> = cmd.split(' ').collect();
    match words.iter().position(|w| *w == flag) {
        Some(i) if i + 1 < words.len() => {
            let mut w: Vec<String> = words.iter().map(|s| s.to_string()).collect();
            w[i + 1] = value.to_string();
            w.join(" ")
        }
        _ => format!("{cmd} {flag} {value}"),
    }
}

/// Applies the module doc's substitutions to one `rwg` command of a line.
fn reduce_rwg(cmd: &str) -> String {
    let mut c = cmd.to_string();
    if c.contains("rwg run ") && c.contains("examples/atlas.toml") {
        // 45 cells, mostly Box2D and MuJoCo envs stepped in Python
        c = set_flag(&c, "--samples", "4");
        c = set_flag(&c, "--episodes", "1");
    } else if c.contains("rwg run ") {
        c = set_flag(&c, "--samples", "32");
        c = set_flag(&c, "--episodes", "4");
    }
    if (c.contains("rwg stats ") || c.contains("rwg report ")) && c.contains(" --at-n ") {
        c = set_flag(&c, "--at-n", "8");
    }
    if c.contains("rwg bench envs") {
        c = set_flag(&c, "--steps", "20000");
    }
    if c.contains("rwg bench sampler") || c.contains("rwg bench gym") {
        c = set_flag(&c, "--samples", "16");
        c = set_flag(&c, "--episodes", "2");
    }
    if c.contains("rwg bench gym") {
        c = set_flag(&c, "--repeats", "1");
    }
    if c.contains("rwg bench plugin") {
        c = set_flag(&c, "--samples", "16");
        c = set_flag(&c, "--episodes", "2");
        c = set_flag(&c, "--rounds", "1");
    }
    if c.contains("rwg bench libm") {
        c = set_flag(&c, "--check", "20000");
        c = set_flag(&c, "--rounds", "1");
        if c.contains(" --pow-check ") {
            c = set_flag(&c, "--pow-check", "20000");
        }
    }
    if c.contains("rwg slurm ") && !c.contains("--dry-run") {
        c.push_str(" --dry-run");
    }
    c
}

fn plan(e: &Example) -> Plan {
    let c = e.command.as_str();
    if c.starts_with("pip install") || c.starts_with("maturin build") {
        return Plan::NotRun(
            "the wheel is built with maturin and installed into a fresh virtualenv by .ci/run's \
             packaging check",
        );
    }
    if c.starts_with("cargo install --path rwg-cli") && c.contains("--no-default-features") {
        return Plan::NotRun(
            "a release build of its own; the build without default features is .ci/run's",
        );
    }
    if c.starts_with("cargo install --path rwg-cli") {
        return Plan::NotRun("provided: rwg is on PATH");
    }
    if c.starts_with("cargo build --release") {
        return Plan::NotRun("provided: target/release holds the test build's rwg and plugins");
    }
    if c.starts_with("cargo test") {
        return Plan::NotRun("this is the test suite");
    }
    if c.contains("jax-atlas") {
        return Plan::NotRun(
            "tests/cli_jax_atlas.rs runs the JAX atlas's commands on one env of it (the \
             whole atlas compiles 132 JAX programs)",
        );
    }
    if c.starts_with("python3 -m pip install") && c.contains("gymnasium") {
        return Plan::NotRun("provided: RWG_PYTHON is RWG_TEST_PYTHON, which holds it");
    }
    if c.starts_with("python3 -m pip install") && needs_jax(c) {
        return Plan::NotRun("provided: RWG_PEER_PYTHON's Python holds jax, gymnax and brax");
    }
    if c.contains("peers-venv") {
        return Plan::NotRun("the JAX peer is not installed by this test (network, ~1 GB)");
    }
    if c.contains("benches/peers/") && !c.contains("rwg bench gym") {
        return Plan::NotRun(
            "the peer scripts need the peers' virtualenv; tests/cli_bench.rs runs them small",
        );
    }
    if c.contains("rwg bench peers") {
        return Plan::NotRun(
            "needs the JAX peer, ~25 min; tests/cli_bench.rs runs it small with RWG_PEER_PYTHON",
        );
    }
    if c.contains("plugin-overhead.sh") {
        return Plan::Run(format!("SAMPLES=32 EPISODES=2 {c}"));
    }
    if c.contains("examples/paper-runtime.py") {
        return Plan::Run(c.replace(
            "examples/paper-runtime.py",
            "examples/paper-runtime.py --samples 8 --repeats 1",
        ));
    }
    if c.contains('\n') {
        // a here-document: a file or a script, as printed
        return Plan::Run(c.to_string());
    }
    // a line may hold several commands (`a; b`, a `for` loop): reduce each
    let parts: Vec<String> = c.split("; ").map(reduce_rwg).collect();
    Plan::Run(parts.join("; "))
}

/// The output shape an example must have, by what it runs.
fn check_shape(e: &Example, ran: &str, dir: &Path, stdout: &str) {
    let c = ran;
    let has = |s: &str| c.contains(s);
    let want = |ok: bool, what: &str| {
        assert!(
            ok,
            "{}: `{}`: {what}\nstdout:\n{stdout}",
            e.source, e.command
        )
    };
    let first_line = c.lines().next().unwrap_or("");
    if let Some((_, file)) = first_line.split_once(" > ") {
        let file = file.split_whitespace().next().unwrap_or("");
        let text = std::fs::read_to_string(dir.join(file)).unwrap_or_default();
        want(
            !text.trim().is_empty(),
            "writes nothing into its output file",
        );
        if has("--json") {
            want(
                serde_json::from_str::<serde_json::Value>(&text).is_ok(),
                "writes no valid JSON",
            );
        }
        return;
    }
    if let Some(rest) = first_line.strip_prefix("python3 -m venv ") {
        let venv = rest.split_whitespace().next().unwrap_or("");
        want(
            dir.join(venv).join("bin/python").exists(),
            "makes no virtualenv",
        );
        return;
    }
    if has("make -C") {
        want(
            dir.join("examples/plugin-c")
                .join(rwg_plugin_host::library_file_name("chain"))
                .is_file(),
            "builds no libchain",
        );
        return;
    }
    want(!stdout.trim().is_empty(), "prints nothing");
    if has("--json") {
        want(
            serde_json::from_str::<serde_json::Value>(stdout).is_ok(),
            "prints no valid JSON",
        );
    }
    let first = stdout.lines().next().unwrap_or("");
    if has("rwg envs") && !has("--json") {
        want(first.starts_with("id "), "prints no table of envs");
    }
    if has("rwg rollout") {
        let ok = if has("--format csv") {
            first.starts_with("step,")
        } else {
            first.starts_with("{\"step\":0,")
        };
        want(ok, "prints no step-0 line");
        want(stdout.lines().count() >= 2, "prints no step");
    }
    if has("rwg run ") && !has("--shard") && !has("; rwg status") {
        want(
            stdout.contains("Results: ") || stdout.contains("already holds this study"),
            "ends without naming the run directory",
        );
    }
    if has("rwg merge ") {
        let out = c
            .rsplit("--out ")
            .next()
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap();
        want(dir.join(out).join("run.json").is_file(), "merges nothing");
    }
    if has("rwg stats") {
        want(
            stdout.contains("Best sample mean") || stdout.contains("\\toprule"),
            "prints no Table 3",
        );
    }
    if has("rwg report ") {
        want(stdout.trim().ends_with("report.html"), "names no report");
        want(dir.join(stdout.trim()).is_file(), "writes no report");
    }
    if has("rwg compare") && has("--paired") {
        // the table's verdict line, or the CSV's verdict column
        want(stdout.contains("verdict"), "prints no verdict");
    } else if has("rwg compare") {
        want(stdout.contains("Difficulty ranking"), "prints no ranking");
        if let Some(f) = c.split("--html ").nth(1) {
            let f = f.split_whitespace().next().unwrap();
            let page = std::fs::read_to_string(dir.join(f)).unwrap_or_default();
            want(
                page.contains("<h2>Difficulty ranking</h2>"),
                "writes no page",
            );
        }
    }
    if has("rwg check") && !has("--json") {
        want(stdout.contains("[ok]"), "reports no passed check");
    }
    if has("rwg slurm") {
        want(stdout.contains("sbatch"), "prints no sbatch command");
    }
    if has("rwg status") {
        want(stdout.lines().count() >= 2, "says little");
    }
    if has("rwg top") {
        want(stdout.contains("rwg replay "), "lists no replay command");
    }
    if has("rwg replay") && has("--episode ") {
        want(first.starts_with("{\"step\":0,"), "prints no step-0 line");
        want(stdout.lines().count() >= 2, "prints no step");
    }
}

/// Runs `cmd` with `sh -c` in `dir`, `bin` first on PATH, `python` (if
/// any) as `RWG_PYTHON` and its folder next on PATH; fails after `limit`.
/// Returns (success, stdout, stderr).
fn sh(
    cmd: &str,
    dir: &Path,
    bin: &Path,
    python: Option<&std::ffi::OsStr>,
    limit: Duration,
) -> (bool, String, String) {
    let python_bin = python
        .and_then(|p| Path::new(p).parent())
        .map_or(String::new(), |d| format!("{}:", d.display()));
    let path = format!(
        "{}:{python_bin}{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(cmd)
        .current_dir(dir)
        .env("PATH", path)
        .env("HOME", dir.join("home"))
        .env_remove("RWG_PLUGIN_PATH")
        .env_remove("RWG_PYTHON")
        .envs(python.map(|p| ("RWG_PYTHON", p)))
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("cannot run sh");
    let (mut so, mut se) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let out = std::thread::spawn(move || std::io::read_to_string(&mut so).unwrap_or_default());
    let err = std::thread::spawn(move || std::io::read_to_string(&mut se).unwrap_or_default());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("`{cmd}` did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    (status.success(), out.join().unwrap(), err.join().unwrap())
}

const TEST: &str = "every_page_and_help_example_runs_as_printed";

/// Runs `examples` in order in `dir`, a fresh reader's clone, each as its
/// [`plan`] says, checking its exit status and output; what was done is
/// added to `notes`.
fn run_in_clone(examples: &[Example], dir: &Path, notes: &mut Vec<String>) {
    std::fs::create_dir_all(dir).unwrap();
    let bin = prepare(dir);
    let python = std::env::var_os("RWG_TEST_PYTHON");
    let jax_python = std::env::var_os("RWG_PEER_PYTHON").filter(|p| !p.is_empty());
    // what the commands skipped would have made: a later command that uses
    // it is skipped too (it would fail for want of it, not for its own sake)
    let mut missing: Vec<String> = vec![];
    for e in examples {
        let ran = match plan(e) {
            Plan::NotRun(why) => {
                notes.push(format!("{}: `{}` not run: {why}", e.source, e.command));
                continue;
            }
            Plan::Run(c) => c,
        };
        if ran != e.command {
            notes.push(format!("{}: `{}` ran as `{ran}`", e.source, e.command));
        }
        let need = needs(&ran, dir);
        let why = if need.gymnasium && python.is_none() {
            Some("RWG_TEST_PYTHON, a Python with gymnasium[box2d,mujoco]".to_string())
        } else if need.jax && jax_python.is_none() {
            Some("RWG_PEER_PYTHON, a Python with jax, gymnax and brax".to_string())
        } else {
            missing
                .iter()
                .find(|m| ran.contains(m.as_str()))
                .map(|m| format!("{m}, which a command skipped before it makes"))
        };
        if let Some(why) = why {
            skip(TEST, &format!("{}: `{}` needs {why}", e.source, e.command));
            missing.extend(outputs(&ran, dir));
            continue;
        }
        let python = if need.jax { &jax_python } else { &python };
        let t = Instant::now();
        let (ok, stdout, stderr) = sh(&ran, dir, &bin, python.as_deref(), Duration::from_secs(300));
        assert!(
            ok,
            "{}: `{}` failed (ran as `{ran}` in {}):\nstdout:\n{stdout}\nstderr:\n{stderr}",
            e.source,
            e.command,
            dir.display()
        );
        assert!(
            !stderr.contains("error:"),
            "{}: `{ran}` printed an error:\n{stderr}",
            e.source
        );
        check_shape(e, &ran, dir, &stdout);
        notes.push(format!(
            "{}: `{ran}` ok in {:.1} s",
            e.source,
            t.elapsed().as_secs_f64()
        ));
    }
}

/// Each page runs in a clone of its own, as a reader who opens it would:
/// its commands may use what earlier commands of the same page made, never
/// another page's. The `--help` examples run after the README's, in its
/// clone (they look at the run of its quick start). Pages are independent,
/// so as many run at once as the machine has cores (much of a page's time is
/// one process's start-up or a JAX compilation, on one core).
#[test]
fn every_page_and_help_example_runs_as_printed() {
    let root = temp_dir("examples");
    let help = help_examples();
    assert!(help.len() >= 15, "help examples found: {help:#?}");
    let started = Instant::now();
    // every page is read before any runs: a page that cannot be parsed fails at once
    let mut pages: Vec<(String, Vec<Example>)> = doc_pages()
        .into_iter()
        .map(|page| {
            let examples = page_examples(&page);
            (page, examples)
        })
        .collect();
    let mut counts = Vec::new();
    for (page, examples) in &mut pages {
        counts.push(format!("{} from {page}", examples.len()));
        if page == "README.md" {
            assert!(examples.len() >= 10, "README examples found: {examples:#?}");
            examples.extend(help.iter().cloned());
        }
        if ["docs/guide.md", "docs/gymnasium.md", "docs/plugins.md"].contains(&page.as_str()) {
            assert!(examples.len() >= 3, "{page}: examples found: {examples:#?}");
        }
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(pages.len());
    let page_notes: Vec<std::sync::Mutex<Vec<String>>> =
        pages.iter().map(|_| Default::default()).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                scope.spawn(|| loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some((page, examples)) = pages.get(i) else {
                        break;
                    };
                    let dir = root.join(page.replace(['/', '.'], "-")).join("rwg");
                    let mut notes = page_notes[i].lock().unwrap_or_else(|e| e.into_inner());
                    run_in_clone(examples, &dir, &mut notes);
                })
            })
            .collect();
        // a page's failure is this test's, with its own message
        for h in handles {
            if let Err(panic) = h.join() {
                std::panic::resume_unwind(panic);
            }
        }
    });
    use std::io::Write;
    let mut err = std::io::stderr();
    for n in page_notes.iter().flat_map(|n| n.lock().unwrap().clone()) {
        let _ = writeln!(err, "example {n}");
    }
    let _ = writeln!(
        err,
        "examples: {}, {} from --help, in {:.0} s on {workers} threads",
        counts.join(", "),
        help.len(),
        started.elapsed().as_secs_f64()
    );
}

/// The pages stay readable: the README at most 300 lines, ARCHITECTURE.md at
/// most 150 with no table cell over 25 words, and no page points outside a
/// clone (`../shared`, a folder beside the developers' checkout).
#[test]
fn pages_keep_to_their_limits() {
    let read = |page: &str| std::fs::read_to_string(repo().join(page)).unwrap();
    let readme = read("README.md").lines().count();
    assert!(readme <= 300, "README.md has {readme} lines; at most 300");
    let arch = read("ARCHITECTURE.md");
    let lines = arch.lines().count();
    assert!(
        lines <= 150,
        "ARCHITECTURE.md has {lines} lines; at most 150"
    );
    for (i, line) in arch.lines().enumerate() {
        if !line.starts_with('|') {
            continue;
        }
        for cell in line.trim_matches('|').split(" | ") {
            let words = cell.split_whitespace().count();
            assert!(
                words <= 25,
                "ARCHITECTURE.md:{}: a cell of {words} words, at most 25: {cell}",
                i + 1
            );
        }
    }
    for page in doc_pages()
        .iter()
        .map(String::as_str)
        .chain(["ARCHITECTURE.md"])
    {
        for (i, line) in read(page).lines().enumerate() {
            assert!(
                !line.contains("../shared"),
                "{page}:{}: names ../shared, which a clone does not have: {line}",
                i + 1
            );
        }
    }
}

#[test]
fn comments_and_continuations_are_read_as_a_reader_would() {
    assert_eq!(strip_comment("rwg envs   # list"), "rwg envs");
    assert_eq!(strip_comment("rwg x --a \"b # c\""), "rwg x --a \"b # c\"");
    assert_eq!(strip_comment("echo $#"), "echo $#");
    assert_eq!(
        heredoc_terminator("cat > f.toml <<'EOF'").as_deref(),
        Some("EOF")
    );
    assert_eq!(
        heredoc_terminator("python3 - <<TOML").as_deref(),
        Some("TOML")
    );
    assert_eq!(heredoc_terminator("rwg run m.toml"), None);
    assert_eq!(
        set_flag("rwg run m.toml --samples 1000 --out x", "--samples", "32"),
        "rwg run m.toml --samples 32 --out x"
    );
    assert_eq!(
        set_flag("rwg run m.toml", "--episodes", "4"),
        "rwg run m.toml --episodes 4"
    );
}
