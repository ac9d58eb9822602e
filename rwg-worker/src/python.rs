//! The Python side shared by rwg's Python workers (the Gymnasium bridge's
//! `worker.py`, rwg-jax's `jax_worker.py`): the module both import for
//! their pipe to rwg ([`PIPE_PY`]: the channels and the framing of
//! `docs/bridge-protocol.md`), and the loader that makes shipped modules
//! importable and runs a worker ([`LOAD_PY`]). Both texts ship inside rwg;
//! nothing is written to disk.

use std::process::Command;

/// The name the workers import [`PIPE_PY`] by.
pub const PIPE_MODULE: &str = "rwg_pipe";

/// The pipe module: importing it keeps private duplicates of stdin/stdout
/// for the protocol (fd 0/1 then go to /dev/null and stderr), ignores
/// SIGINT, enables faulthandler (SIGUSR1 dumps the stacks), and gives the
/// functions that read and write framed messages.
pub const PIPE_PY: &str = include_str!("rwg_pipe.py");

/// The loader, run as `python -c LOAD_PY WORKER [NAME SOURCE]...`: runs
/// each module's source as the module `NAME`, in order, then `WORKER` as
/// the main program.
pub const LOAD_PY: &str = include_str!("load.py");

/// Adds [`LOAD_PY`]'s arguments to `command` (after `-c` and the loader's
/// text): the worker program, then each module's name and source.
pub fn loader_args(command: &mut Command, worker: &str, modules: &[(&str, &str)]) {
    command.arg(worker);
    for (name, source) in modules {
        command.arg(name).arg(source);
    }
}
