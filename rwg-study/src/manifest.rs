//! The TOML manifest that drives a study.
//!
//! ```toml
//! seed = 0             # optional, default 0
//! samples = 1000       # networks per cell
//! episodes = 20        # episodes per network
//! out = "runs/quick"   # optional run directory (relative to the current directory)
//! threads = 2          # optional, default: all cores
//! bias = [false, true] # optional, default [false]
//!
//! [weights]            # optional, default normal with scale 1
//! distribution = "normal"  # or "uniform"
//! scale = 1.0              # std of the normal, or a of U(-a, a)
//!
//! [[architectures]]
//! name = "0HL"
//! hidden = []
//!
//! [[architectures]]        # optional: the random baseline, one cell per env
//! name = "random"
//! policy = "random"        # uniformly random actions instead of networks
//!
//! [[envs]]
//! id = "CartPole-v0"
//! solved = 195             # optional, overrides the env's reward threshold
//! max_episode_steps = 200  # optional, overrides the env's time limit
//! action_dtype = "float64" # optional: float64 (default) or float32
//!
//! [[envs]]
//! id = "acme/Maze-v0"
//! plugin = "plugins/libacme.so"  # optional: the plugin library providing the env
//!                                # (relative to the manifest's folder)
//! config = "size=9"              # optional, plugin envs only: given to the plugin verbatim
//! isolate = true                 # optional: run it in worker processes (crash-safe, see
//!                                # rwg_study::isolate); no effect on built-in and gymnasium: envs
//!
//! [[envs]]
//! id = "gymnasium:LunarLander-v3"   # a Gymnasium env, run through Python (rwg-gym)
//! kwargs = { continuous = true }     # optional: gym.make's keyword arguments
//! python = ".venv/bin/python"        # optional: default RWG_PYTHON, then python3
//!
//! [[envs]]
//! id = "gymnax:CartPole-v1"          # a JAX env (also brax:, playground:, jumanji:, ...), rwg-jax
//! precision = "float64"              # optional: float32 (default) or float64; part of the study
//! matmul_precision = "high"          # optional: highest (default), high, default; part of study
//! device = "gpu:1"                   # optional: one device (default: every device of one kind)
//! networks_per_call = 1024           # optional: networks in one compiled call (a multiple of 32);
//!                                    # how, not what: a resume may change it
//! action_mask = false                # optional: plain argmax where the family gives legal actions
//! non_finite = "end"                 # optional, any env: an episode meeting a NaN or infinite
//!                                    # value ends there, flagged (default "stop": the study stops)
//! ```
//!
//! Unknown keys and bad values are errors that name the file, line, column
//! and key; nothing runs.
//!
//! This module holds the manifest's types, its loading and what is derived
//! from it (the resolved manifest, study differences); the text as TOML reads
//! it is in `raw`, and each section is checked in a module of its own
//! (`top_keys`, `weights`, `architectures`, `envs` with `jax_keys` and
//! [`kwargs`]).

use crate::limits;
use crate::manifest_text;
use checker::{locate, Checker};
use raw::Raw;
use rwg_core::policy::PolicyKind;
use rwg_core::sampler::{NonFinite, WeightDist};
use rwg_env::env::ActionDtype;
use serde::Serialize;
use std::ops::Range;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A manifest error, located in its file.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}:{line}:{column}: {message}")]
pub struct ManifestError {
    /// The manifest file.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// What is wrong, starting with the key.
    pub message: String,
}

/// A manifest that could not be read at all.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ManifestLoadError {
    /// The file could not be read.
    #[error("cannot read manifest {file}")]
    Io {
        /// The manifest file.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file was read but is not a valid manifest.
    #[error(transparent)]
    Invalid(#[from] ManifestError),
}

/// A named architecture of the manifest.
#[derive(Debug, Clone, Serialize)]
pub struct ArchEntry {
    /// Name used in output (cell directories, tables).
    pub name: String,
    /// Hidden layer sizes (none for random actions).
    pub hidden: Vec<usize>,
    /// Networks (the default, not written), or `policy = "random"`:
    /// uniformly random actions, one cell per env whatever `bias` says.
    #[serde(
        skip_serializing_if = "architectures::is_network",
        serialize_with = "architectures::serialize_policy"
    )]
    pub policy: PolicyKind,
    /// Where the name stands in the manifest (byte range), for error messages.
    #[serde(skip)]
    pub name_span: Range<usize>,
}

impl ArchEntry {
    /// The bias settings this entry has cells for, of the manifest's `bias`:
    /// all of them for networks; one (no bias) for random actions, which
    /// have no network.
    pub fn biases<'a>(&self, bias: &'a [bool]) -> &'a [bool] {
        match self.policy {
            PolicyKind::Network => bias,
            PolicyKind::Random => &[false],
        }
    }
}

impl PartialEq for ArchEntry {
    /// Equal names, layers and policies (where they stand in the text does
    /// not count).
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name && self.hidden == other.hidden && self.policy == other.policy
    }
}

/// An environment of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EnvEntry {
    /// Environment id.
    pub id: String,
    /// Solved score override.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solved: Option<f64>,
    /// Time limit override.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_episode_steps: Option<u32>,
    /// dtype of continuous actions; `None` for a JAX env, which takes none
    /// (its actions are of its `precision`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub action_dtype: Option<ActionDtype>,
    /// Plugin library providing the env (resolved against the manifest's
    /// folder; absolute when the manifest was read with [`Manifest::load`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plugin: Option<PathBuf>,
    /// Config string given verbatim to a plugin env's `create`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config: Option<String>,
    /// Keyword arguments of `gym.make` (`gymnasium:` envs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kwargs: Option<toml::Table>,
    /// The Python interpreter of a `gymnasium:` env (a path with a `/` is
    /// resolved against the manifest's folder; a bare name is looked up on PATH).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub python: Option<String>,
    /// Run a plugin env in worker processes (`rwg_study::isolate`); no
    /// effect on other envs. How, not what: not part of the study (see
    /// [`Manifest::study_differences`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub isolate: bool,
    /// The precision a JAX env (`gymnax:`, `brax:`, `jax:`) computes in:
    /// the manifest's, else float32; `None` for every other env. Part of
    /// the study.
    #[serde(
        skip_serializing_if = "Option::is_none",
        serialize_with = "jax_keys::serialize_name"
    )]
    pub precision: Option<rwg_jax::Precision>,
    /// The precision of a JAX env's matrix products (the manifest's, else
    /// `highest`); `None` for every other env. Part of the study.
    #[serde(
        skip_serializing_if = "Option::is_none",
        serialize_with = "jax_keys::serialize_name"
    )]
    pub matmul_precision: Option<rwg_jax::MatmulPrecision>,
    /// The JAX device a JAX env runs on (`cpu`, `gpu:1`; `None`: JAX's
    /// first). How, not what: not part of the study (the device used is
    /// recorded in each cell's `env.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// Networks in one compiled call of a JAX env (`None`: rwg-jax's
    /// default, from the lanes and the device's memory). How, not what: a
    /// network's results do not depend on it, so it is not part of the study.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub networks_per_call: Option<u32>,
    /// Whether a JAX env's discrete action is the argmax over the legal
    /// actions where its family gives them: `Some(true)` unless the manifest
    /// says `action_mask = false`; `None` for every other env. Part of the
    /// study.
    #[serde(skip_serializing_if = "jax_keys::mask_is_default")]
    pub action_mask: Option<bool>,
    /// What an episode that meets a value that is not finite does: stop
    /// the study (the default, not written out) or end the episode there,
    /// flagged. Part of the study.
    #[serde(
        skip_serializing_if = "is_stop",
        serialize_with = "serialize_non_finite"
    )]
    pub non_finite: NonFinite,
    /// Where the `device` value stands, if given.
    #[serde(skip)]
    pub device_span: Option<Range<usize>>,
    /// Where the `kwargs` value stands, if given.
    #[serde(skip)]
    pub kwargs_span: Option<Range<usize>>,
    /// Where the `python` value stands, if given.
    #[serde(skip)]
    pub python_span: Option<Range<usize>>,
    /// Where the id stands in the manifest (byte range), for error messages.
    #[serde(skip)]
    pub id_span: Range<usize>,
    /// Where the `plugin` value stands, if given.
    #[serde(skip)]
    pub plugin_span: Option<Range<usize>>,
    /// Where the `config` value stands, if given.
    #[serde(skip)]
    pub config_span: Option<Range<usize>>,
}

fn is_stop(n: &NonFinite) -> bool {
    *n == NonFinite::Stop
}

/// Writes `non_finite` as the manifest spells it (`"end"`).
fn serialize_non_finite<S: serde::Serializer>(n: &NonFinite, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(n.name())
}

/// A validated manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// Master seed.
    pub seed: u64,
    /// Networks per cell.
    pub samples: u64,
    /// Episodes per network.
    pub episodes: u32,
    /// Run directory, if given.
    pub out: Option<PathBuf>,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Bias settings to run.
    pub bias: Vec<bool>,
    /// Weight distribution.
    pub weights: WeightDist,
    /// Architectures.
    pub architectures: Vec<ArchEntry>,
    /// Environments.
    pub envs: Vec<EnvEntry>,
    /// The manifest's file name, for messages.
    pub file: String,
    /// The manifest's text, for locating errors.
    pub source: String,
}

impl Manifest {
    /// Reads and validates a manifest file. Plugin paths become absolute
    /// (resolved against the manifest's folder), so the resolved manifest
    /// ([`Manifest::to_toml`]) names the same files wherever it is written.
    pub fn load(path: &Path) -> Result<Manifest, ManifestLoadError> {
        let file = path.display().to_string();
        let io = |source| ManifestLoadError::Io {
            file: file.clone(),
            source,
        };
        let too_large = |has: String| {
            locate(
                &file,
                "",
                0..0,
                format!(
                    "the file {has} bytes; a manifest has at most {} (rwg's limit)",
                    limits::MAX_MANIFEST_BYTES
                ),
            )
        };
        let size = std::fs::metadata(path).map_err(io)?.len();
        if size > limits::MAX_MANIFEST_BYTES {
            return Err(too_large(format!("has {size}")).into());
        }
        // the size a device or pipe states (none) is not what it holds
        let bytes = match limits::read_bounded(path, limits::MAX_MANIFEST_BYTES) {
            Err(e) if e.kind() == std::io::ErrorKind::FileTooLarge => {
                let has = format!("holds more than {}", limits::MAX_MANIFEST_BYTES);
                return Err(too_large(has).into());
            }
            r => r.map_err(io)?,
        };
        let text = manifest_text::decode(&bytes).map_err(|e| {
            let valid = std::str::from_utf8(&bytes[..e.offset]).unwrap_or("");
            locate(&file, valid, e.offset..e.offset, e.message)
        })?;
        let base = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let base = std::path::absolute(base).map_err(|source| ManifestLoadError::Io {
            file: file.clone(),
            source,
        })?;
        Ok(Manifest::parse(text, &file, &base)?)
    }

    /// An error located at `span` of this manifest's text.
    pub fn error_at(&self, span: Range<usize>, message: impl Into<String>) -> ManifestError {
        locate(&self.file, &self.source, span, message.into())
    }

    /// Validates manifest text. `file` names it in errors; relative plugin
    /// paths are resolved against `base`. The sections are checked in turn
    /// (top-level keys, `[weights]`, `[[architectures]]`, `[[envs]]`); the
    /// first error is returned.
    pub fn parse(text: &str, file: &str, base: &Path) -> Result<Manifest, ManifestError> {
        let at = Checker { file, text };
        let raw = read_raw(&at)?;
        let seed = top_keys::seed(&at, raw.seed.as_ref())?;
        let samples = top_keys::samples(&at, &raw.samples)?;
        let episodes = top_keys::episodes(&at, &raw.episodes)?;
        let threads = top_keys::threads(&at, raw.threads.as_ref())?;
        let out = top_keys::out(&at, raw.out)?;
        let bias = top_keys::bias(&at, raw.bias.as_ref())?;
        let weights = weights::weights(&at, raw.weights.as_ref())?;
        let architectures = architectures::architectures(&at, &raw.architectures)?;
        let envs = envs::envs(&at, &raw.envs, base)?;
        Ok(Manifest {
            seed,
            samples,
            episodes,
            out,
            threads,
            bias,
            weights,
            architectures,
            envs,
            file: file.to_string(),
            source: text.to_string(),
        })
    }

    /// The study the manifest defines, as TOML with every value written out
    /// (the run directory's `manifest.toml`). `out` and `threads` are left out:
    /// they say where and how fast, not what, so runs of the same study written
    /// to different places or with different thread counts have identical
    /// manifests. Reading it back gives the same study.
    pub fn to_toml(&self) -> String {
        #[derive(Serialize)]
        struct Weights<'a> {
            distribution: &'a str,
            scale: f64,
        }
        #[derive(Serialize)]
        struct Study<'a> {
            seed: u64,
            samples: u64,
            episodes: u32,
            bias: &'a [bool],
            weights: Weights<'a>,
            architectures: &'a [ArchEntry],
            envs: &'a [EnvEntry],
        }
        let o = Study {
            seed: self.seed,
            samples: self.samples,
            episodes: self.episodes,
            bias: &self.bias,
            weights: Weights {
                distribution: self.weights.name(),
                scale: self.weights.scale(),
            },
            architectures: &self.architectures,
            envs: &self.envs,
        };
        toml::to_string(&o).expect("manifest serialises")
    }

    /// Runs every env that can be isolated in worker processes
    /// (`--isolate`): all but JAX envs, which always run in worker processes
    /// of their own and take no `isolate` (the resolved manifest must read
    /// back).
    pub fn isolate_all(&mut self) {
        for e in &mut self.envs {
            e.isolate = rwg_jax::jax_id(&e.id).is_none();
        }
    }

    /// How the study of `other` differs from this one (empty: the same study),
    /// one `key: this vs other` line per key that differs, down to the entry
    /// and key (`envs[1] (ID).kwargs.g: 9.8 vs 9.0`; a NaN equals itself).
    /// Compares what [`Manifest::to_toml`] writes, key by key, except the
    /// envs' `isolate`, `device` and `networks_per_call` (they change where
    /// or how an env runs, not its results; the kind of device a JAX cell
    /// ran on is compared through its `env.json`,
    /// [`crate::rundir::env_record`]).
    pub fn study_differences(&self, other: &Manifest) -> Vec<String> {
        let study = |m: &Manifest| {
            let mut t: toml::Table = toml::from_str(&m.to_toml()).expect("valid TOML");
            if let Some(toml::Value::Array(envs)) = t.get_mut("envs") {
                for e in envs.iter_mut().filter_map(|e| e.as_table_mut()) {
                    e.remove("isolate");
                    e.remove("device");
                    e.remove("networks_per_call");
                }
            }
            t
        };
        diff::differences(&study(self), &study(other))
    }
}

/// The manifest's text as TOML reads it: no NUL, valid TOML, no unknown
/// key (with a suggestion for a misspelt one).
fn read_raw(at: &Checker) -> Result<Raw, ManifestError> {
    manifest_text::check_no_nul(at.text).map_err(|e| at.err(e.offset..e.offset, e.message))?;
    manifest_text::from_toml(at.text).map_err(|(span, mut msg)| {
        if let Some(s) = unknown_field_suggestion(&msg) {
            msg.push_str(&s);
        }
        at.err(span, msg)
    })
}

/// "did you mean ...?" for serde's "unknown field `x`, expected one of `a`, `b`" messages.
fn unknown_field_suggestion(msg: &str) -> Option<String> {
    const PREFIX: &str = "unknown key `";
    let rest = &msg[msg.find(PREFIX)? + PREFIX.len()..];
    let (field, rest) = rest.split_once('`')?;
    let expected: Vec<&str> = rest.split('`').skip(1).step_by(2).collect();
    rwg_env::suggest::nearest(field, expected.iter().copied())
        .map(|s| format!(" (did you mean `{s}`?)"))
}

mod architectures;
mod checker;
mod diff;
mod envs;
mod jax_keys;
pub mod kwargs;
mod raw;
mod top_keys;
mod weights;

#[cfg(test)]
mod tests;
