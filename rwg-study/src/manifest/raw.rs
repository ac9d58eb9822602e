//! The manifest as TOML reads it, before any check: every value with where
//! it stands in the text, and unknown keys refused by serde.

use super::kwargs::RawKwargs;
use serde::Deserialize;
use toml::Spanned;

/// A number written as a TOML integer or float.
#[derive(Debug, Clone, Copy)]
pub(super) enum Num {
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
    /// The number as a float.
    pub(super) fn get(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::Float(f) => f,
        }
    }
}

/// The whole manifest: its top-level keys and its three sections.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Raw {
    pub(super) seed: Option<Spanned<i64>>,
    pub(super) samples: Spanned<i64>,
    pub(super) episodes: Spanned<i64>,
    pub(super) out: Option<Spanned<String>>,
    pub(super) threads: Option<Spanned<i64>>,
    pub(super) bias: Option<Spanned<Vec<bool>>>,
    pub(super) weights: Option<RawWeights>,
    pub(super) architectures: Spanned<Vec<RawArch>>,
    pub(super) envs: Spanned<Vec<RawEnv>>,
}

/// The `[weights]` table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawWeights {
    pub(super) distribution: Option<Spanned<String>>,
    pub(super) scale: Option<Spanned<Num>>,
}

/// One `[[architectures]]` entry.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawArch {
    pub(super) name: Spanned<String>,
    pub(super) hidden: Option<Spanned<Vec<Spanned<i64>>>>,
    pub(super) policy: Option<Spanned<String>>,
}

/// One `[[envs]]` entry.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEnv {
    pub(super) id: Spanned<String>,
    pub(super) solved: Option<Spanned<Num>>,
    pub(super) max_episode_steps: Option<Spanned<i64>>,
    pub(super) action_dtype: Option<Spanned<String>>,
    pub(super) plugin: Option<Spanned<String>>,
    pub(super) config: Option<Spanned<String>>,
    pub(super) kwargs: Option<Spanned<RawKwargs>>,
    pub(super) python: Option<Spanned<String>>,
    pub(super) isolate: Option<Spanned<bool>>,
    pub(super) precision: Option<Spanned<String>>,
    pub(super) matmul_precision: Option<Spanned<String>>,
    pub(super) device: Option<Spanned<String>>,
    pub(super) networks_per_call: Option<Spanned<i64>>,
    pub(super) action_mask: Option<Spanned<bool>>,
    pub(super) non_finite: Option<Spanned<String>>,
}
