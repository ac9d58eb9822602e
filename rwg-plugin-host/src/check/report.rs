//! The checks' results and how they are reported as they run.

use std::panic::{catch_unwind, AssertUnwindSafe};

use serde::{Deserialize, Serialize};

/// The verdict of one check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CheckStatus {
    /// The check passed.
    Passed,
    /// Allowed, but probably not what the author wants.
    Warned,
    /// The environment breaks the contract.
    Failed,
}

/// One check's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckResult {
    /// The environment id, or `None` for a check of the plugin file itself.
    pub env: Option<String>,
    /// The check's name, e.g. `"reset determinism"`.
    pub name: String,
    /// The verdict.
    pub status: CheckStatus,
    /// What was found.
    pub message: String,
}

impl std::fmt::Display for CheckResult {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self.status {
            CheckStatus::Passed => "ok",
            CheckStatus::Warned => "WARN",
            CheckStatus::Failed => "FAIL",
        };
        match &self.env {
            Some(e) => write!(f, "[{s}] {e}: {}: {}", self.name, self.message),
            None => write!(f, "[{s}] {}: {}", self.name, self.message),
        }
    }
}

/// The progress of the checks, reported as they run by the `*_observed`
/// functions. A host that runs the checks in a child process streams these,
/// so that when the plugin crashes the child it knows which check did it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CheckEvent<'a> {
    /// A check is about to run (`env` is `None` before the first instance
    /// of a [`check_env`](crate::check::check_env) run exists).
    Started {
        /// The environment id, if known yet.
        env: Option<&'a str>,
        /// The check's name.
        name: &'a str,
    },
    /// A check finished with this result.
    Finished(&'a CheckResult),
}

/// The results of one run of checks, reported to an observer as they come.
pub(super) struct Report<'o> {
    /// The environment id, once known.
    pub(super) env: Option<String>,
    /// The results so far.
    pub(super) results: Vec<CheckResult>,
    observe: &'o mut dyn FnMut(CheckEvent<'_>),
}

impl<'o> Report<'o> {
    pub(super) fn new(env: Option<String>, observe: &'o mut dyn FnMut(CheckEvent<'_>)) -> Self {
        Report {
            env,
            results: Vec::new(),
            observe,
        }
    }

    /// Tells the observer that check `name` starts.
    pub(super) fn start(&mut self, name: &str) {
        (self.observe)(CheckEvent::Started {
            env: self.env.as_deref(),
            name,
        });
    }

    /// Records a result and tells the observer.
    pub(super) fn add(&mut self, name: &str, status: CheckStatus, message: impl Into<String>) {
        self.results.push(CheckResult {
            env: self.env.clone(),
            name: name.to_string(),
            status,
            message: message.into(),
        });
        (self.observe)(CheckEvent::Finished(
            self.results.last().expect("just pushed"),
        ));
    }

    /// Runs a check, turning a panic into a failure.
    pub(super) fn run(&mut self, name: &str, f: impl FnOnce() -> (CheckStatus, String)) {
        self.start(name);
        let (status, msg) = match catch_unwind(AssertUnwindSafe(f)) {
            Ok(r) => r,
            Err(p) => (
                CheckStatus::Failed,
                format!("panicked: {}", panic_text(&*p)),
            ),
        };
        self.add(name, status, msg);
    }
}

/// The message of a panic payload.
pub(super) fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-string panic payload".into())
}
