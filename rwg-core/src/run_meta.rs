//! The run directory's metadata file, `run.json`, shared by the code that
//! writes runs and the code that analyses them.
//!
//! A run directory holds:
//! - `manifest.toml`: the resolved manifest (every default and command-line
//!   override written out), enough to re-run the study;
//! - `run.json`: [`RunMeta`];
//! - `cells/<cell dir>/scores.csv`: one row per episode,
//!   `sample,episode,score,steps`;
//! - `cells/<cell dir>/samples.csv`: one row per sample,
//!   `sample,mean,variance,std,min,max,rank`.

use serde::{Deserialize, Serialize};

/// Version of the run directory layout.
pub const RUN_FORMAT: u32 = 1;

/// Contents of `run.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMeta {
    /// Run directory layout version ([`RUN_FORMAT`]).
    pub format: u32,
    /// Version of rwg that wrote the run.
    pub rwg_version: String,
    /// Manifest seed.
    pub seed: u64,
    /// Networks per cell.
    pub samples: u64,
    /// Episodes per network.
    pub episodes: u32,
    /// Weight distribution.
    pub weights: WeightsMeta,
    /// Worker threads used.
    pub threads: usize,
    /// Start time (UTC, RFC 3339).
    pub start_time: String,
    /// End time (UTC, RFC 3339); `None` while the run is incomplete.
    pub end_time: Option<String>,
    /// Wall time of the sampling in seconds.
    pub wall_s: f64,
    /// Environment steps over all cells.
    pub env_steps: u64,
    /// `env_steps / wall_s`.
    pub steps_per_s: f64,
    /// One entry per cell, in manifest order (env, then architecture, then bias).
    pub cells: Vec<CellMeta>,
}

/// The weight distribution of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeightsMeta {
    /// `normal` (scale = standard deviation) or `uniform` (scale = a for U(-a, a)).
    pub distribution: String,
    /// The distribution's scale.
    pub scale: f64,
}

/// One cell: an environment × architecture × bias setting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellMeta {
    /// Directory of the cell under `cells/`.
    pub dir: String,
    /// Environment id.
    pub env: String,
    /// Architecture name from the manifest (e.g. `0HL`, `1HL-4`).
    pub arch: String,
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Whether the networks have bias inputs.
    pub bias: bool,
    /// Weights per network.
    pub n_weights: usize,
    /// Observation length.
    pub obs_dim: usize,
    /// Time limit used.
    pub max_episode_steps: u32,
    /// Score at or above which a sample's mean counts as solved (`None`: not set).
    pub solved: Option<f64>,
    /// Where `solved` came from: `manifest` or `env` (the env's reward threshold).
    pub solved_source: Option<String>,
    /// Networks in the cell.
    pub samples: u64,
    /// Episodes per network.
    pub episodes: u32,
    /// Wall time of the cell in seconds.
    pub wall_s: f64,
    /// Environment steps of the cell.
    pub env_steps: u64,
    /// `env_steps / wall_s`.
    pub steps_per_s: f64,
}

/// The directory name of a cell: `<env>__<arch>__<bias|nobias>`, with
/// characters other than ASCII letters, digits, `-`, `_` and `.` replaced by `_`
/// (plugin ids may contain `/`).
pub fn cell_dir_name(env: &str, arch: &str, bias: bool) -> String {
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect()
    };
    format!(
        "{}__{}__{}",
        clean(env),
        clean(arch),
        if bias { "bias" } else { "nobias" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_dir_names() {
        assert_eq!(
            cell_dir_name("CartPole-v0", "0HL", false),
            "CartPole-v0__0HL__nobias"
        );
        assert_eq!(
            cell_dir_name("acme/Maze-v2", "2HL 4,4", true),
            "acme_Maze-v2__2HL_4_4__bias"
        );
    }
}
