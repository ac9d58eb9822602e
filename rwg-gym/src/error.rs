//! What can go wrong with a Gymnasium environment ([`GymError`]) and how
//! the bridge's failures read.

use crate::protocol::WorkerError;
use crate::{START_TIMEOUT_VAR, TIMEOUT_VAR};
use rwg_core::remote::RemoteFailure;
use rwg_env::EnvError;
use rwg_worker::host::Describe;
use rwg_worker::ProcError;
use thiserror::Error;

/// What can go wrong with a Gymnasium environment.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GymError {
    /// The interpreter could not be started.
    #[error(
        "cannot run Python '{python}': {reason}; install Python 3 with Gymnasium \
             (python3 -m pip install gymnasium), or name the interpreter with `python = \"...\"` \
             in the manifest or the RWG_PYTHON environment variable"
    )]
    NoPython {
        /// The interpreter.
        python: String,
        /// Why it did not start (in this text, so not the error's source:
        /// the text is complete where it is shown without its chain).
        reason: std::io::Error,
    },
    /// The worker reported a fatal error (import, registration, make, spaces...).
    #[error("{}", worker_error_text(.python, .error))]
    Worker {
        /// The interpreter.
        python: String,
        /// What it reported.
        error: WorkerError,
    },
    /// The worker process ended.
    #[error("the Python worker {how}{}", tail(.stderr))]
    Died {
        /// How it ended ("was killed by signal 11 (SIGSEGV)").
        how: String,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker did not answer in time.
    #[error("the Python worker did not answer within {secs} s (the environment hangs in reset or step?) \
             and was killed; set {TIMEOUT_VAR} (seconds) to allow more{}", tail(.stderr))]
    Timeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// The worker did not finish starting in time.
    #[error("the Python worker did not start within {secs} s (importing the env's module and \
             making its instances with gym.make) and was killed; set {START_TIMEOUT_VAR} \
             (seconds) to allow more{}", tail(.stderr))]
    StartTimeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// A reset or step of the checks made when a worker starts did not
    /// return in time.
    #[error("the Python worker did not answer within {secs} s in a reset or step of the checks \
             rwg makes when a worker starts (the environment hangs in reset or step?) and was \
             killed; set {TIMEOUT_VAR} (seconds) to allow more{}", tail(.stderr))]
    CheckTimeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr (with the traceback of where it hung).
        stderr: String,
    },
    /// A worker describes the env otherwise than the first worker did.
    #[error("another worker process of the env (pid {pid}) reports other spaces than the first \
             one did: {}; rwg runs every episode of a cell under one set of spaces, so they must \
             not depend on the process (on environment variables, files or random numbers the \
             env reads when it is made)", .differences.join("; "))]
    OtherSpaces {
        /// The worker's process id.
        pid: u32,
        /// What differs, one entry each: `what: first's, this one's`.
        differences: Vec<String>,
    },
    /// The worker said something unexpected.
    #[error("bridge protocol error: {0}")]
    Protocol(String),
}

use rwg_worker::stderr_tail_text as tail;

impl From<ProcError> for GymError {
    fn from(e: ProcError) -> Self {
        match e {
            ProcError::Spawn { program, source } => GymError::NoPython {
                python: program,
                reason: source,
            },
            ProcError::Died { how, stderr } => GymError::Died { how, stderr },
            ProcError::Timeout { secs, stderr } => GymError::Timeout { secs, stderr },
            ProcError::Protocol(m) => GymError::Protocol(m),
            other => GymError::Protocol(other.to_string()),
        }
    }
}

/// How the bridge's failures read.
pub(crate) const DESCRIBE: Describe = Describe {
    proc: |e| GymError::from(e).into(),
    fatal: |python, error| {
        GymError::Worker {
            python: python.to_string(),
            error,
        }
        .into()
    },
    traceback: "Python traceback",
};

fn worker_error_text(python: &str, e: &WorkerError) -> String {
    let mut s = match e.kind.as_str() {
        "python" => format!(
            "Gymnasium is not installed for {python}: {}; install it with:\n  {python} -m pip install \"gymnasium[box2d,mujoco]\"\n(or name another interpreter with `python = \"...\"` in the manifest or RWG_PYTHON)",
            e.message
        ),
        "not_registered" => format!(
            "Gymnasium has no such environment: {} (for an env of your own package, write \
             gymnasium:your_module:YourEnv-v0 so that rwg imports the module first)",
            e.message
        ),
        _ => e.message.clone(),
    };
    if !e.traceback.trim().is_empty() {
        s.push_str("\nPython traceback:\n");
        s.push_str(e.traceback.trim_end());
    }
    s
}

impl From<GymError> for EnvError {
    fn from(e: GymError) -> Self {
        EnvError::Other(e.to_string())
    }
}

impl From<GymError> for RemoteFailure {
    fn from(e: GymError) -> Self {
        RemoteFailure {
            lane: None,
            between_calls: false,
            error: e.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    /// A Python that cannot start: the reason is in the text, once, and not
    /// chained as well (a printer of the chain would repeat it).
    #[test]
    fn no_python_says_why_once() {
        let e = GymError::from(ProcError::Spawn {
            program: "/nonexistent/python3".into(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file xyz"),
        });
        let text = e.to_string();
        assert!(
            text.starts_with("cannot run Python '/nonexistent/python3': no such file xyz; install"),
            "{text}"
        );
        assert!(e.source().is_none(), "{:?}", e.source());
    }
}
