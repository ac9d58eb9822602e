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
//! id = "gymnax:CartPole-v1"          # a JAX env (also brax:NAME, jax:module:callable), rwg-jax
//! precision = "float64"              # optional: float32 (default) or float64; part of the study
//! device = "gpu:1"                   # optional: the JAX device (default: JAX's first)
//! networks_per_call = 1024           # optional: networks in one compiled call (a multiple of 32)
//! ```
//!
//! Unknown keys and bad values are errors that name the file, line, column
//! and key; nothing runs.

use crate::limits::{self, in_range, short_enough};
use crate::manifest_text::{self, line_col};
use rwg_core::sampler::WeightDist;
use rwg_env::env::ActionDtype;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::{Path, PathBuf};
use thiserror::Error;
use toml::Spanned;

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

/// A number written as a TOML integer or float.
#[derive(Debug, Clone, Copy)]
enum Num {
    Int(i64),
    Float(f64),
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Num;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number (an integer such as 195 or a float such as -140.5)")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Num, E> {
                Ok(Num::Int(v))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Num, E> {
                Ok(Num::Float(v as f64))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Num, E> {
                Ok(Num::Float(v))
            }
        }
        d.deserialize_any(V)
    }
}

impl Num {
    fn get(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::Float(f) => f,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    seed: Option<Spanned<i64>>,
    samples: Spanned<i64>,
    episodes: Spanned<i64>,
    out: Option<Spanned<String>>,
    threads: Option<Spanned<i64>>,
    bias: Option<Spanned<Vec<bool>>>,
    weights: Option<RawWeights>,
    architectures: Spanned<Vec<RawArch>>,
    envs: Spanned<Vec<RawEnv>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWeights {
    distribution: Option<Spanned<String>>,
    scale: Option<Spanned<Num>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawArch {
    name: Spanned<String>,
    hidden: Spanned<Vec<Spanned<i64>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnv {
    id: Spanned<String>,
    solved: Option<Spanned<Num>>,
    max_episode_steps: Option<Spanned<i64>>,
    action_dtype: Option<Spanned<String>>,
    plugin: Option<Spanned<String>>,
    config: Option<Spanned<String>>,
    kwargs: Option<Spanned<kwargs::RawKwargs>>,
    python: Option<Spanned<String>>,
    isolate: Option<Spanned<bool>>,
    precision: Option<Spanned<String>>,
    device: Option<Spanned<String>>,
    networks_per_call: Option<Spanned<i64>>,
}

/// A named architecture of the manifest.
#[derive(Debug, Clone, Serialize)]
pub struct ArchEntry {
    /// Name used in output (cell directories, tables).
    pub name: String,
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Where the name stands in the manifest (byte range), for error messages.
    #[serde(skip)]
    pub name_span: Range<usize>,
}

impl PartialEq for ArchEntry {
    /// Equal names and layers (where they stand in the text does not count).
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name && self.hidden == other.hidden
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
    /// dtype of continuous actions.
    pub action_dtype: ActionDtype,
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
        serialize_with = "jax_keys::serialize_precision"
    )]
    pub precision: Option<rwg_jax::Precision>,
    /// The JAX device a JAX env runs on (`cpu`, `gpu:1`; `None`: JAX's
    /// first). How, not what: not part of the study (the device used is
    /// recorded in each cell's `env.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// Networks in one compiled call of a JAX env (`None`: rwg-jax's
    /// default for the device's platform). Part of the study.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub networks_per_call: Option<u32>,
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
    /// paths are resolved against `base`.
    pub fn parse(text: &str, file: &str, base: &Path) -> Result<Manifest, ManifestError> {
        let err = |span: Range<usize>, msg: String| locate(file, text, span, msg);
        manifest_text::check_no_nul(text).map_err(|e| err(e.offset..e.offset, e.message))?;
        let raw: Raw = manifest_text::from_toml(text).map_err(|(span, mut msg)| {
            if let Some(s) = unknown_field_suggestion(&msg) {
                msg.push_str(&s);
            }
            err(span, msg)
        })?;

        // A count in `min..=max`, else an error stating the limit.
        let count =
            |v: &Spanned<i64>, key: &str, min: i64, max: u64| -> Result<u64, ManifestError> {
                in_range(
                    key,
                    *v.get_ref(),
                    min,
                    i64::try_from(max).unwrap_or(i64::MAX),
                )
                .map(|v| v as u64)
                .map_err(|m| err(v.span(), m))
            };
        // A string of at most `max` bytes.
        let short = |v: &Spanned<String>, key: &str, max: usize| -> Result<(), ManifestError> {
            short_enough(key, v.get_ref(), max).map_err(|m| err(v.span(), m))
        };

        let seed = match &raw.seed {
            None => 0,
            Some(s) if *s.get_ref() >= 0 => *s.get_ref() as u64,
            Some(s) => {
                return Err(err(
                    s.span(),
                    format!("seed: must be a non-negative integer, got {}", s.get_ref()),
                ))
            }
        };
        let samples = count(&raw.samples, "samples", 1, limits::MAX_SAMPLES)?;
        let episodes = count(&raw.episodes, "episodes", 1, limits::MAX_EPISODES.into())? as u32;
        let threads = raw
            .threads
            .as_ref()
            .map(|t| count(t, "threads", 1, limits::MAX_THREADS as u64).map(|t| t as usize))
            .transpose()?;
        if let Some(o) = &raw.out {
            short(o, "out", limits::MAX_PATH_BYTES)?;
        }
        let bias = match &raw.bias {
            None => vec![false],
            Some(b) if b.get_ref().is_empty() => {
                return Err(err(
                    b.span(),
                    "bias: needs at least one setting (false, true or both)".into(),
                ))
            }
            Some(b) => {
                let mut v = b.get_ref().clone();
                v.dedup();
                if v.len() != b.get_ref().len() || (v.len() == 2 && v[0] == v[1]) {
                    return Err(err(b.span(), "bias: each setting may appear once".into()));
                }
                v
            }
        };

        let weights = match &raw.weights {
            None => WeightDist::Normal { std: 1.0 },
            Some(w) => {
                let scale = match &w.scale {
                    None => 1.0,
                    Some(s) => {
                        let v = s.get_ref().get();
                        if !(v.is_finite() && v > 0.0) {
                            return Err(err(
                                s.span(),
                                format!("weights.scale: must be a positive number, got {v}"),
                            ));
                        }
                        v
                    }
                };
                let dist = match w.distribution.as_ref().map(|d| (d.get_ref().as_str(), d.span())) {
                    None | Some(("normal", _)) => WeightDist::Normal { std: scale },
                    Some(("uniform", _)) => WeightDist::Uniform { a: scale },
                    Some((other, span)) => {
                        return Err(err(
                            span,
                            format!("weights.distribution: unknown distribution '{other}' (expected \"normal\" or \"uniform\")"),
                        ))
                    }
                };
                if let (Some(s), false) = (&w.scale, scale <= dist.max_scale()) {
                    return Err(err(
                        s.span(),
                        format!(
                            "weights.scale: {scale:e} is beyond what a {} distribution's draws \
                             can take without overflowing a 64-bit float to infinity; the scale \
                             must be above 0 and at most {:e}",
                            dist.name(),
                            dist.max_scale()
                        ),
                    ));
                }
                dist
            }
        };

        if raw.architectures.get_ref().is_empty() {
            return Err(err(
                raw.architectures.span(),
                "architectures: needs at least one architecture".into(),
            ));
        }
        if raw.architectures.get_ref().len() > limits::MAX_ARCHITECTURES {
            return Err(err(
                raw.architectures.get_ref()[limits::MAX_ARCHITECTURES]
                    .name
                    .span(),
                format!(
                    "architectures: at most {} (rwg's limit), got {}",
                    limits::MAX_ARCHITECTURES,
                    raw.architectures.get_ref().len()
                ),
            ));
        }
        let mut architectures = Vec::new();
        for (i, a) in raw.architectures.get_ref().iter().enumerate() {
            let key = format!("architectures[{i}]");
            let name = a.name.get_ref().trim().to_string();
            if name.is_empty() {
                return Err(err(a.name.span(), format!("{key}.name: must not be empty")));
            }
            short(&a.name, &format!("{key}.name"), limits::MAX_ARCH_NAME_BYTES)?;
            if a.hidden.get_ref().len() > limits::MAX_HIDDEN_LAYERS {
                return Err(err(
                    a.hidden.span(),
                    format!(
                        "{key}.hidden: at most {} layers (rwg's limit), got {}",
                        limits::MAX_HIDDEN_LAYERS,
                        a.hidden.get_ref().len()
                    ),
                ));
            }
            if architectures.iter().any(|x: &ArchEntry| x.name == name) {
                return Err(err(
                    a.name.span(),
                    format!("{key}.name: '{name}' is used twice"),
                ));
            }
            let mut hidden = Vec::new();
            for (j, h) in a.hidden.get_ref().iter().enumerate() {
                if !(1..=limits::MAX_LAYER_UNITS as i64).contains(h.get_ref()) {
                    return Err(err(
                        h.span(),
                        format!(
                            "{key}.hidden[{j}]: a layer needs 1 to {} units (rwg's limit), got {}",
                            limits::MAX_LAYER_UNITS,
                            h.get_ref()
                        ),
                    ));
                }
                hidden.push(*h.get_ref() as usize);
            }
            architectures.push(ArchEntry {
                name,
                hidden,
                name_span: a.name.span(),
            });
        }

        if raw.envs.get_ref().is_empty() {
            return Err(err(
                raw.envs.span(),
                "envs: needs at least one environment".into(),
            ));
        }
        if raw.envs.get_ref().len() > limits::MAX_ENVS {
            return Err(err(
                raw.envs.get_ref()[limits::MAX_ENVS].id.span(),
                format!(
                    "envs: at most {} (rwg's limit), got {}",
                    limits::MAX_ENVS,
                    raw.envs.get_ref().len()
                ),
            ));
        }
        let mut envs: Vec<EnvEntry> = Vec::new();
        for (i, e) in raw.envs.get_ref().iter().enumerate() {
            let key = format!("envs[{i}]");
            short(&e.id, &format!("{key}.id"), limits::MAX_ENV_ID_BYTES)?;
            if let Some(c) = &e.config {
                short(c, &format!("{key}.config"), limits::MAX_CONFIG_BYTES)?;
            }
            if let Some(p) = &e.plugin {
                short(p, &format!("{key}.plugin"), limits::MAX_PATH_BYTES)?;
                crate::plugin_path::check_value(&key, p.get_ref()).map_err(|m| err(p.span(), m))?;
            }
            let id = e.id.get_ref().clone();
            if envs.iter().any(|x| x.id == id) {
                let hint = if crate::gym_source::is_gym(&id) {
                    " (one entry per id, as the id enters the seeds and the cell names: for \
                     another configuration of the env use a registered id of its own, e.g. \
                     gymnasium:LunarLanderContinuous-v3 beside gymnasium:LunarLander-v3, or a \
                     second manifest)"
                } else {
                    ""
                };
                return Err(err(
                    e.id.span(),
                    format!("{key}.id: '{id}' is listed twice{hint}"),
                ));
            }
            let solved = match &e.solved {
                None => None,
                Some(s) if s.get_ref().get().is_finite() => Some(s.get_ref().get()),
                Some(s) => {
                    return Err(err(
                        s.span(),
                        format!("{key}.solved: must be a finite number"),
                    ))
                }
            };
            let max_episode_steps = match &e.max_episode_steps {
                None => None,
                Some(m) => Some(count(
                    m,
                    &format!("{key}.max_episode_steps"),
                    1,
                    limits::MAX_EPISODE_STEPS.into(),
                )? as u32),
            };
            let action_dtype = match &e.action_dtype {
                None => ActionDtype::F64,
                Some(d) => d
                    .get_ref()
                    .parse()
                    .map_err(|m: String| err(d.span(), format!("{key}.action_dtype: {m}")))?,
            };
            let jax = jax_keys::check(&key, &id, e).map_err(|(span, msg)| err(span, msg))?;
            let plugin = e.plugin.as_ref().map(|p| {
                let p = Path::new(p.get_ref());
                if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    base.join(p)
                }
            });
            envs.push(EnvEntry {
                id,
                solved,
                max_episode_steps,
                action_dtype,
                plugin,
                config: e.config.as_ref().map(|c| c.get_ref().clone()),
                kwargs: match &e.kwargs {
                    None => None,
                    Some(k) => Some(
                        k.get_ref()
                            .to_table(&format!("{key}.kwargs"))
                            .map_err(|(span, msg)| err(span, msg))?,
                    ),
                },
                python: e.python.as_ref().map(|p| {
                    let v = p.get_ref();
                    if v.contains('/') && !Path::new(v).is_absolute() {
                        base.join(v).to_string_lossy().into_owned()
                    } else {
                        v.clone()
                    }
                }),
                isolate: e.isolate.as_ref().is_some_and(|i| *i.get_ref()),
                precision: jax.precision,
                device: jax.device,
                networks_per_call: jax.networks_per_call,
                device_span: e.device.as_ref().map(|d| d.span()),
                kwargs_span: e.kwargs.as_ref().map(|k| k.span()),
                python_span: e.python.as_ref().map(|p| p.span()),
                id_span: e.id.span(),
                plugin_span: e.plugin.as_ref().map(|p| p.span()),
                config_span: e.config.as_ref().map(|c| c.span()),
            });
        }

        Ok(Manifest {
            seed,
            samples,
            episodes,
            out: raw.out.map(|o| PathBuf::from(o.into_inner())),
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
            e.isolate = !crate::jax_source::is_jax(&e.id);
        }
    }

    /// How the study of `other` differs from this one (empty: the same study).
    /// Compares what [`Manifest::to_toml`] writes, key by key, except the
    /// envs' `isolate` and `device` (they change where an env runs, not its
    /// results; the device a JAX cell ran on is compared through its
    /// `env.json`, [`crate::rundir::env_record`]).
    pub fn study_differences(&self, other: &Manifest) -> Vec<String> {
        let study = |m: &Manifest| {
            let mut t: toml::Table = toml::from_str(&m.to_toml()).expect("valid TOML");
            if let Some(toml::Value::Array(envs)) = t.get_mut("envs") {
                for e in envs.iter_mut().filter_map(|e| e.as_table_mut()) {
                    e.remove("isolate");
                    e.remove("device");
                }
            }
            t
        };
        let (a, b) = (study(self), study(other));
        let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
        keys.sort();
        keys.dedup();
        keys.into_iter()
            .filter(|k| a.get(*k) != b.get(*k))
            .map(|k| {
                let show =
                    |v: Option<&toml::Value>| v.map_or("(absent)".to_string(), |v| v.to_string());
                format!("{k}: {} vs {}", show(a.get(k)), show(b.get(k)))
            })
            .collect()
    }
}

fn locate(file: &str, text: &str, span: Range<usize>, message: String) -> ManifestError {
    let (line, column) = line_col(text, span.start);
    ManifestError {
        file: file.to_string(),
        line,
        column,
        message,
    }
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

mod jax_keys;
pub mod kwargs;

#[cfg(test)]
mod tests;
