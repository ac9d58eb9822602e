//! `rwg`: Random Weight Guessing analysis of reinforcement-learning environments.

// rwg's own output goes through `outln!`/`stdio::stdout()`: fd 1 carries what
// plugins print (see `stdio::protect`), so a plain `println!` would land on stderr.
// Its messages go through `errln!`: `eprintln!` panics when stderr is closed.
#![deny(clippy::print_stdout, clippy::print_stderr)]

mod cluster;
mod cmd;
mod details;
mod ending;
mod env_vars;
mod errors;
mod fault_guard;
mod gym;
mod progress;
mod slurm_script;
mod stdio;
mod step_lines;
mod summary;
mod timing_table;

use anyhow::Result;

/// The system allocator, recording a failed allocation (see [`ending::Allocator`]).
#[global_allocator]
static ALLOCATOR: ending::Allocator = ending::Allocator;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Measure how hard an RL benchmark really is by Random Weight Guessing:
/// sample small neural-network controllers with random weights, run them, and
/// look at the distribution of their scores.
#[derive(Parser)]
#[command(name = "rwg", version, about, long_about = None, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the available environments with their spaces, time limit and solved score.
    Envs(cmd::envs::Args),
    /// Run one episode of an environment with given actions and print every step.
    Rollout(cmd::rollout::Args),
    /// Run the RWG study a TOML manifest describes and write a run directory.
    Run(cmd::run::Args),
    /// Combine the shards of a study (`rwg run --shard K/N`) into one run directory.
    Merge(cmd::merge::Args),
    /// Submit a study to Slurm: a job array of shards and a merge job that depends on it.
    Slurm(cmd::slurm::Args),
    /// Which cells, blocks and shards of a run or sharded study are done, and how to finish it.
    Status(cmd::status::Args),
    /// Regenerate one network of a run from its seed, re-run it, or export its weights.
    Replay(cmd::replay::Args),
    /// List the best networks of each cell of a run, with the command that replays each.
    Top(cmd::top::Args),
    /// Check a run directory's files against their checksums; exit 1 on any mismatch.
    Verify(cmd::verify::Args),
    /// Statistics of a run: the paper's Table 3, p(solved), expected guesses.
    Stats(cmd::stats::Args),
    /// Figures of a run: per cell histogram, scores by rank, variance; overview grids.
    Plot(cmd::plot::Args),
    /// One self-contained HTML report of a run: metadata, tables, figures, manifest.
    Report(cmd::report::Args),
    /// Compare envs across runs: p(solved), 1/p, best mean, normalised scores.
    Compare(cmd::compare::Args),
    /// Check that a plugin's environments keep the contract (each in a child process).
    Check(cmd::check::Args),
    /// Internal: one environment's checks for `rwg check`, as JSON lines.
    #[command(name = "__check-child", hide = true)]
    CheckChild(cmd::check::ChildArgs),
    /// Internal: an isolated plugin env's worker process for `rwg run --isolate`.
    #[command(name = "__plugin-worker", hide = true)]
    PluginWorker,
    /// Measure env steps/s: raw environments, or the RWG sampler vs the peer implementations.
    Bench(cmd::bench::Args),
}

/// The error and its causes, `: `-separated, without repeating a cause its
/// parent's message already ends with (errors that print their source).
fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let msg = cause.to_string();
        if text.ends_with(&msg) || msg.is_empty() {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&msg);
    }
    text
}

/// Panics (bugs in rwg) are reported in rwg's own `error:` style, with
/// where they happened, instead of Rust's "thread panicked" text.
fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        if let Some(e) = ending::thread_start_failure(&msg) {
            fault_guard::exit_on_resource_error(&e);
        }
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        // never a panic here: a second one would abort
        stdio::write_err(&format!(
            "error: internal error (a bug in rwg, please report it){at}: {msg}\n"
        ));
    }));
}

/// The exit status of `--help`, `--version` or a usage error, printed by
/// clap; a closed pipe is told as for any other output.
fn clap_status(e: clap::Error) -> i32 {
    let status = e.exit_code();
    match e.print() {
        Err(io) if status == 0 && io.kind() == std::io::ErrorKind::BrokenPipe => {
            stdio::CLOSED_PIPE_STATUS
        }
        Err(io) if status == 0 => {
            errln!("error: cannot write to standard output: {io}");
            1
        }
        _ => status,
    }
}

/// `status` (0, 1, 2, 130 or [`stdio::CLOSED_PIPE_STATUS`]) as the process's exit code.
fn exit_code(status: i32) -> ExitCode {
    ExitCode::from(u8::try_from(status).unwrap_or(1))
}

fn main() -> ExitCode {
    ending::set_up();
    install_panic_hook();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return exit_code(clap_status(e)),
    };
    cmd::pin_env_paths();
    // From here on, what a plugin prints goes to stderr, never into rwg's output.
    stdio::protect();
    if let Err(e) = env_vars::check_all() {
        errln!("error: {e}");
        return exit_code(1);
    }
    let result = run_command(cli.command);
    // A command cut short by a signal rwg ends by: that signal's report is
    // the message, and its status the exit status.
    ending::wait_if_ending();
    let status = status_of(result);
    fault_guard::finished_unless_said(format!(
        "rwg's work was done (exit status {status}): its output and files are complete."
    ));
    exit_code(stdio::exit_status(status))
}

/// Runs a command; its exit status when it succeeds: 0, or `rwg run`'s own
/// (130 after an interrupt, 1 after a failed cell, each reported already).
fn run_command(command: Command) -> Result<i32> {
    let done = match command {
        Command::Run(a) => return cmd::run::run(a),
        Command::Envs(a) => cmd::envs::run(a),
        Command::Rollout(a) => cmd::rollout::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::Slurm(a) => cmd::slurm::run(a),
        Command::Status(a) => cmd::status::run(a),
        Command::Replay(a) => cmd::replay::run(a),
        Command::Top(a) => cmd::top::run(a),
        Command::Verify(a) => cmd::verify::run(a),
        Command::Stats(a) => cmd::stats::run(a),
        Command::Plot(a) => cmd::plot::run(a),
        Command::Report(a) => cmd::report::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Check(a) => cmd::check::run(a),
        Command::CheckChild(a) => cmd::check::run_child(a),
        Command::PluginWorker => cmd::plugin_worker::run(),
        Command::Bench(a) => cmd::bench::run(a),
    };
    done.map(|()| 0)
}

/// The exit status of a command's result, its error printed (with a hint
/// where one helps) before it is returned.
fn status_of(result: Result<i32>) -> i32 {
    match result {
        Ok(status) => status,
        // a command's output to a closed pipe (`rwg ... | head`) ends it as
        // SIGPIPE would, without a message
        Err(e) if stdio::stdout_closed() && stdio::is_closed_pipe(&e) => stdio::CLOSED_PIPE_STATUS,
        Err(e) => {
            let text = match stdio::stdout_error() {
                // a bare I/O error passed up from a write to stdout
                Some(out) if e.chain().count() == 1 && e.is::<std::io::Error>() => {
                    format!("cannot write to standard output: {out}")
                }
                _ => details::one_line(&error_text(&e), None),
            };
            errln!("error: {text}");
            // (args() would panic on an argument that is not UTF-8)
            let args: Vec<String> = std::env::args_os()
                .skip(2)
                .map(|a| a.to_string_lossy().into_owned())
                .collect();
            if let Some(h) = errors::hint(&e, &args) {
                errln!("hint: {h}");
            }
            1
        }
    }
}
