//! Conformance checks for environments and plugins, after Gymnasium's
//! `utils/env_checker.py`: the library behind `rwg check`.
//!
//! [`check_env`] works on any [`Environment`] given a constructor;
//! [`check_plugin_env`] adds the checks only the raw ABI can express, and
//! [`check_plugin`] loads a file and checks every environment in it.
//!
//! The checks run in this process. A plugin that crashes (a segfault, an
//! abort) takes the process with it, so `rwg check` should run
//! [`check_plugin_env`] in a child process per environment. Panics of Rust
//! environments checked through [`check_env`] are caught and reported.
//!
//! Results are [`CheckStatus::Passed`], [`CheckStatus::Warned`] (legal but
//! suspicious, as Gymnasium's checker warns) or [`CheckStatus::Failed`] (the
//! contract is broken).
//!
//! The files: [`report`] (results and their reporting), `env_checks` (one
//! function per environment check), `plugin_checks` (the checks that need
//! the raw ABI), `batch_checks` (ABI 1.1's batched calls against the single
//! ones), `trajectory` (actions and recorded trajectories).

mod batch_checks;
mod env_checks;
mod plugin_checks;
pub mod report;
mod trajectory;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use crate::loader::{load_plugin, PluginEnvType};
use report::panic_text;
use report::Report;
pub use report::{CheckEvent, CheckResult, CheckStatus};
use rwg_env::env::Environment;
use rwg_env::space::Space;
use CheckStatus::{Failed, Passed};

/// Runs the environment checks on instances built by `make`.
///
/// `make` must build a fresh instance each call, without a time limit or
/// with one (the truncation check applies the spec's limit itself). It is
/// called from several threads.
pub fn check_env<E, Er, F>(make: F) -> Vec<CheckResult>
where
    E: Environment,
    Er: std::fmt::Display,
    F: Fn() -> Result<E, Er> + Sync,
{
    check_env_observed(make, &mut |_| {})
}

/// [`check_env`], reporting every check to `observe` as it starts and ends.
pub fn check_env_observed<E, Er, F>(
    make: F,
    observe: &mut dyn FnMut(CheckEvent<'_>),
) -> Vec<CheckResult>
where
    E: Environment,
    Er: std::fmt::Display,
    F: Fn() -> Result<E, Er> + Sync,
{
    let mut r = Report::new(None, observe);
    r.start("create");
    let first = match catch_unwind(AssertUnwindSafe(&make)) {
        Ok(Ok(e)) => e,
        Ok(Err(e)) => {
            r.add("create", Failed, format!("cannot create an instance: {e}"));
            return r.results;
        }
        Err(p) => {
            r.add("create", Failed, format!("panicked: {}", panic_text(&*p)));
            return r.results;
        }
    };
    let spec = first.spec().clone();
    drop(first);
    r.env = Some(spec.id.clone());
    r.add("create", Passed, "an instance was created");
    r.run("spaces", || env_checks::spaces(&spec));
    if r.results.last().map(|c| c.status) == Some(Failed) {
        return r.results;
    }
    let fresh = || make().map_err(|e| format!("cannot create an instance: {e}"));
    let fresh: trajectory::Fresh<'_, E> = &fresh;

    for (name, check) in env_checks::in_order::<E>() {
        r.run(name, || check(fresh, &spec));
    }
    r.results
}

/// [`check_env`] on a plugin environment plus the checks that need the raw
/// ABI: id style, non-integral and wrongly sized discrete actions, reset
/// without a seed, and the batched calls against the single ones. Instances are created with `config`.
pub fn check_plugin_env(ty: &PluginEnvType, config: &str) -> Vec<CheckResult> {
    check_plugin_env_observed(ty, config, &mut |_| {})
}

/// [`check_plugin_env`], reporting every check to `observe` as it starts and
/// ends (what `rwg check`'s child process streams to its parent).
pub fn check_plugin_env_observed(
    ty: &PluginEnvType,
    config: &str,
    observe: &mut dyn FnMut(CheckEvent<'_>),
) -> Vec<CheckResult> {
    // The id is known before any instance exists: name it in every result.
    let mut results = check_env_observed(|| ty.create(config), &mut |ev| match ev {
        CheckEvent::Started { name, .. } => observe(CheckEvent::Started {
            env: Some(ty.id()),
            name,
        }),
        CheckEvent::Finished(r) if r.env.is_none() => observe(CheckEvent::Finished(&CheckResult {
            env: Some(ty.id().to_string()),
            ..r.clone()
        })),
        ev => observe(ev),
    });
    for r in &mut results {
        r.env.get_or_insert_with(|| ty.id().to_string());
    }
    let mut r = Report::new(Some(ty.id().to_string()), observe);
    let id = ty.id();
    r.run("id", || plugin_checks::id(id));
    if let Space::Discrete { .. } = ty.spec().action_space {
        r.run("raw discrete actions", || {
            plugin_checks::raw_discrete_actions(ty, config)
        });
    }
    r.run("unseeded reset", || {
        plugin_checks::unseeded_reset(ty, config)
    });
    r.run("batched calls", || batch_checks::batched_calls(ty, config));
    r.run("vector env", || batch_checks::vec_env(ty, config));
    results.extend(r.results);
    results
}

/// Loads the plugin file and checks every environment in it with config `""`.
/// A file that does not load gives one failed `"load"` result with the reason.
/// Runs in this process: a crashing plugin crashes it (see the module docs).
pub fn check_plugin(path: &Path) -> Vec<CheckResult> {
    let mut quiet = |_: CheckEvent<'_>| {};
    let mut r = Report::new(None, &mut quiet);
    r.start("load");
    let plugin = match load_plugin(path) {
        Ok(p) => p,
        Err(e) => {
            r.add("load", Failed, e.to_string());
            return r.results;
        }
    };
    let info = plugin.info();
    r.add(
        "load",
        Passed,
        format!(
            "plugin '{}' {} (ABI {}.{}), {} environment(s)",
            info.id,
            info.version,
            info.abi.0,
            info.abi.1,
            plugin.envs().len()
        ),
    );
    for ty in plugin.envs() {
        r.results.extend(check_plugin_env(ty, ""));
    }
    r.results
}
