//! Every `RWG_*` environment variable rwg reads, checked before a command
//! runs (before anything is created): a bad value is an error naming the
//! variable, never a silent default nor a panic later. The variables the
//! libraries read are checked through their own accessors, which parse them
//! with [`rwg_env::vars`] as this module does.

use rwg_env::vars::{self, VarError};
use std::time::Duration;

/// The progress line's interval of `rwg run` without a terminal.
pub const PROGRESS_INTERVAL_VAR: &str = "RWG_PROGRESS_INTERVAL";
/// The default progress interval, seconds.
pub const DEFAULT_PROGRESS_INTERVAL_S: f64 = 5.0;
/// How long finished blocks gather before a commit.
pub const COMMIT_LINGER_VAR: &str = "RWG_COMMIT_LINGER";

/// [`PROGRESS_INTERVAL_VAR`]: seconds from 0 (a line per block) to a day.
pub fn progress_interval() -> Result<Duration, VarError> {
    vars::seconds(
        PROGRESS_INTERVAL_VAR,
        0.0,
        86_400.0,
        Duration::from_secs_f64(DEFAULT_PROGRESS_INTERVAL_S),
        "the time between progress lines; 0: a line per block",
    )
}

/// [`COMMIT_LINGER_VAR`]: seconds from 0 to 3600, else
/// [`rwg_study::committer::LINGER`].
pub fn commit_linger() -> Result<Duration, VarError> {
    vars::seconds(
        COMMIT_LINGER_VAR,
        0.0,
        3600.0,
        rwg_study::committer::LINGER,
        "how long finished blocks gather before they are committed; 0 commits each block at once",
    )
}

/// One variable's check.
type Check = fn() -> Result<(), VarError>;

/// Every variable rwg reads with its check. `RWG_PLUGIN_PATH` (a list of
/// folders) and the `rwg bench peers` variables (paths, read by its
/// arguments) take any value but the empty string.
pub const CHECKS: [(&str, Check); 14] = [
    (rwg_plugin_host::PLUGIN_PATH_VAR, || {
        vars::not_empty(
            rwg_plugin_host::PLUGIN_PATH_VAR,
            "folders of plugin libraries, colon-separated",
        )
    }),
    ("RWG_PEER_PYTHON", || {
        vars::not_empty("RWG_PEER_PYTHON", "the Python of `rwg bench peers`' peer")
    }),
    ("RWG_PEERS_DIR", || {
        vars::not_empty("RWG_PEERS_DIR", "the folder of `rwg bench peers`' scripts")
    }),
    (PROGRESS_INTERVAL_VAR, || progress_interval().map(drop)),
    (COMMIT_LINGER_VAR, || commit_linger().map(drop)),
    (rwg_gym::TIMEOUT_VAR, || {
        rwg_gym::timeout_setting().map(drop)
    }),
    (rwg_gym::START_TIMEOUT_VAR, || {
        rwg_gym::start_timeout_setting().map(drop)
    }),
    (rwg_gym::PYTHON_VAR, || rwg_gym::python_setting().map(drop)),
    (rwg_jax::TIMEOUT_VAR, || {
        rwg_jax::timeout_setting().map(drop)
    }),
    (rwg_jax::CACHE_VAR, || rwg_jax::cache_setting().map(drop)),
    (rwg_study::plugin_batch::BATCH_VAR, || {
        rwg_study::plugin_batch::calls_settings().map(drop)
    }),
    (rwg_study::plugin_batch::VEC_VAR, || {
        rwg_study::plugin_batch::calls_settings().map(drop)
    }),
    (rwg_study::runner::LOCKSTEP_VAR, || {
        rwg_study::runner::lockstep_setting().map(drop)
    }),
    (rwg_env::simd::VAR, || rwg_env::simd::setting().map(drop)),
];

/// Checks every variable of [`CHECKS`]: the first bad one is the error.
pub fn check_all() -> Result<(), VarError> {
    CHECKS.iter().try_for_each(|(_, check)| check())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unset_variables_pass_with_their_defaults() {
        // the end-to-end tests set each, good and bad
        if CHECKS.iter().any(|(v, _)| std::env::var_os(v).is_some()) {
            return;
        }
        assert_eq!(check_all(), Ok(()));
        assert_eq!(progress_interval(), Ok(Duration::from_secs(5)));
        assert_eq!(commit_linger(), Ok(rwg_study::committer::LINGER));
    }
}
