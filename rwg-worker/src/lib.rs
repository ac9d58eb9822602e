//! # rwg-worker: environments in worker processes, stepped in lockstep
//!
//! An environment that should not (or cannot) run in rwg's own process runs
//! in **worker processes**: each hosts `groups × lanes` instances and resets
//! or steps a whole group in one exchange over its stdin/stdout, in the
//! binary format of `docs/bridge-protocol.md` ([`protocol`]). Two workers
//! speak it:
//!
//! - the Gymnasium bridge's Python program (`rwg-gym`, `gymnasium:` envs),
//! - rwg itself as `rwg __plugin-worker`, hosting native plugin envs when
//!   they are isolated (`isolate = true`, `rwg run --isolate`; the plugin
//!   side is `rwg_study::isolate`).
//!
//! This crate is both sides of the protocol: [`process`] starts a worker and
//! reads its answers with a deadline (and says how it ended when it dies),
//! [`host`] is the [`rwg_core::remote::RemoteEnv`] over a started worker (what
//! the remote sampler drives), and [`serve`] is the worker's loop over
//! instances of any [`rwg_env::Environment`].
//!
//! # Example
//!
//! The host asks a group's lanes to reset or step in one framed message;
//! the worker reads it off its stdin and decodes it (here through a buffer
//! rather than a pipe):
//!
//! ```
//! use rwg_core::remote::{LaneActions, LaneOp};
//! use rwg_worker::protocol::{decode_step, encode_step, read_message, TAG_STEP};
//!
//! // Group 0: lane 0 resets with seed 7, lane 1 steps with discrete action 1.
//! let ops = [LaneOp::Reset(7), LaneOp::Step];
//! let actions = LaneActions { discrete: &[0, 1], continuous: &[] };
//! let mut bytes = Vec::new();
//! encode_step(&mut bytes, 0, &ops, actions, 0);
//!
//! let (tag, payload) = read_message(&mut bytes.as_slice())?.expect("a message");
//! assert_eq!(tag, TAG_STEP);
//! let request = decode_step(&payload, 2, 0)?;
//! assert_eq!((request.group, request.ops.as_slice()), (0, &ops[..]));
//! assert_eq!(i64::from_le_bytes(request.words[1]), 1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//!
//! - [`process`]: spawning a worker, reading its answers with a deadline,
//!   [`describe_status`] for how it ended.
//! - [`protocol`]: the binary messages of `docs/bridge-protocol.md`.
//! - [`host`]: [`PipeLanes`], the `RemoteEnv` over a started worker.
//! - [`lane_file`]: the shared 8-byte file naming the instance in a call, so a
//!   worker that dies mid-call is reported with its episode.
//! - [`serve`]: a Rust worker's loop over instances of any `Environment`.
//! - [`python`]: the pipe module rwg's Python workers import and the loader
//!   that ships it to them.
//! - [`family`]: every process a worker starts ends with it and with rwg
//!   (its process group; a subreaper and a mark for those that leave it).

pub mod family;
pub mod host;
pub mod lane_file;
pub mod process;
pub mod protocol;
pub mod python;
pub mod serve;

pub use host::PipeLanes;
pub use process::{describe_status, Worker};

use thiserror::Error;

/// What can go wrong with a worker process, whatever it hosts. The callers
/// (`rwg-gym`, `rwg_study::isolate`) turn these into messages that say what
/// to do for their kind of worker.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ProcError {
    /// The program could not be started. Why is the error's source (not
    /// repeated in this text).
    #[error("cannot start {program}")]
    Spawn {
        /// The program.
        program: String,
        /// Why it did not start.
        source: std::io::Error,
    },
    /// The worker process ended (or stopped answering).
    #[error("the worker {how}{}", stderr_tail_text(.stderr))]
    Died {
        /// How it ended ("was killed by signal 11 (SIGSEGV)").
        how: String,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker did not answer in time and was killed.
    #[error("the worker did not answer within {secs} s and was killed{}", stderr_tail_text(.stderr))]
    Timeout {
        /// The limit.
        secs: f64,
        /// The end of its stderr.
        stderr: String,
    },
    /// The worker said something unexpected.
    #[error("worker protocol error: {0}")]
    Protocol(String),
}

/// `"; the end of its stderr:\n..."`, or nothing for an empty stderr.
pub fn stderr_tail_text(stderr: &str) -> String {
    if stderr.trim().is_empty() {
        String::new()
    } else {
        format!("{}{stderr}", DETAIL_MARKS[2].0)
    }
}

/// Where the long part of a worker's error text starts, as the messages of
/// rwg-gym, rwg-jax, [`host`] and [`stderr_tail_text`] write it, and what it
/// is: a Python traceback, a plugin worker's traceback, a worker's stderr.
pub const DETAIL_MARKS: [(&str, &str); 3] = [
    ("\nPython traceback:\n", "the Python traceback"),
    ("\ntraceback:\n", "the traceback"),
    (
        "; the end of its stderr:\n",
        "the end of the worker's stderr",
    ),
];

/// `text` split where its long part starts (the first of
/// [`DETAIL_MARKS`]): the message before it, what the long part is, and
/// the long part from its label on. `None` for a text without one. The
/// `rwg` binary keeps the long part in a file and prints the short one.
pub fn split_details(text: &str) -> Option<(&str, &'static str, &str)> {
    DETAIL_MARKS
        .iter()
        .filter_map(|(mark, what)| text.find(mark).map(|at| (at, mark, *what)))
        .min_by_key(|(at, _, _)| *at)
        .map(|(at, mark, what)| {
            let label = at + mark.len() - mark.trim_start_matches(['\n', ';', ' ']).len();
            (&text[..at], what, &text[label..])
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn details_split_at_their_first_label() {
        let t = "env X failed (Python py)\nPython traceback:\nTraceback ...\n  line";
        assert_eq!(
            split_details(t),
            Some((
                "env X failed (Python py)",
                "the Python traceback",
                "Python traceback:\nTraceback ...\n  line"
            ))
        );
        let t = format!("the worker exited{}", stderr_tail_text("boom\n"));
        assert_eq!(
            split_details(&t),
            Some((
                "the worker exited",
                "the end of the worker's stderr",
                "the end of its stderr:\nboom\n"
            ))
        );
        assert_eq!(split_details("one line; nothing long"), None);
    }
    use std::error::Error as _;

    /// A program that cannot start: the reason is chained, not repeated in
    /// the text (a printer of the chain shows it once).
    #[test]
    fn spawn_chains_why() {
        let e = ProcError::Spawn {
            program: "/nonexistent/worker".into(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file xyz"),
        };
        assert_eq!(e.to_string(), "cannot start /nonexistent/worker");
        assert_eq!(e.source().unwrap().to_string(), "no such file xyz");
    }
}
