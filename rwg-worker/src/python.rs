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

/// The rwg modules (`rwg_*`) a shipped Python text imports at the start of a
/// line (`from rwg_x import`, `import rwg_x`), in the order it names them:
/// what a crate's list of shipped modules must load before that text.
pub fn rwg_imports(source: &str) -> Vec<&str> {
    source
        .lines()
        .filter_map(|line| {
            let rest = line
                .strip_prefix("from ")
                .or_else(|| line.strip_prefix("import "))?;
            let name = rest.split([' ', ',', '.']).next()?;
            name.starts_with("rwg_").then_some(name)
        })
        .collect()
}

/// Checks that each of `modules` (name, source), loaded in order, is loaded
/// after every rwg module it imports, and that `worker` imports only modules
/// of the list; the first problem, in words.
pub fn check_load_order(worker: &str, modules: &[(&str, &str)]) -> Result<(), String> {
    let names: Vec<&str> = modules.iter().map(|(name, _)| *name).collect();
    for (k, (name, source)) in modules.iter().enumerate() {
        if let Some(import) = rwg_imports(source)
            .into_iter()
            .find(|i| !names[..k].contains(i))
        {
            return Err(format!(
                "{name} imports {import}, which is not loaded before it: {names:?}"
            ));
        }
    }
    match rwg_imports(worker).into_iter().find(|i| !names.contains(i)) {
        Some(import) => Err(format!("the worker imports {import}, not among {names:?}")),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_module_imported_before_it_is_loaded_is_named() {
        let a = "from rwg_pipe import fail\nimport json\n";
        let b = "from rwg_a import x\nimport rwg_pipe\n";
        assert_eq!(rwg_imports(b), ["rwg_a", "rwg_pipe"]);
        let ok = [("rwg_pipe", ""), ("rwg_a", a), ("rwg_b", b)];
        assert_eq!(check_load_order("import rwg_b\n", &ok), Ok(()));
        let late = [("rwg_pipe", ""), ("rwg_b", b), ("rwg_a", a)];
        let e = check_load_order("", &late).unwrap_err();
        assert!(
            e.starts_with("rwg_b imports rwg_a, which is not loaded before it"),
            "{e}"
        );
        let e = check_load_order("from rwg_c import y\n", &ok).unwrap_err();
        assert!(e.starts_with("the worker imports rwg_c"), "{e}");
    }
}
