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

use crate::rundir::{CELL_JSON, RUN_JSON};
use crate::StudyError;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the run directory layout: 2 added the `SHA256SUMS` checksum
/// index ([`crate::rundir::checksum`]). Format 1 runs are read as unverified
/// by the analysis and cannot be resumed or merged.
pub const RUN_FORMAT: u32 = 2;

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
    /// One entry per finished cell, in manifest order (env, then architecture,
    /// then bias).
    pub cells: Vec<CellMeta>,
    /// Samples per block (the unit of commits and shards).
    #[serde(default)]
    pub block_samples: u64,
    /// Set when the directory holds one shard of a study (`rwg run --shard`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<ShardMeta>,
    /// The study: the resolved manifest, as `manifest.toml` holds it, so an
    /// edit of `manifest.toml` is found ([`crate::rundir::study`]). Absent
    /// in runs written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub study: Option<String>,
}

/// Which share of a study a shard directory holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardMeta {
    /// 0-based shard index.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl ShardMeta {
    /// Whether block `block` of cell `cell` (of `blocks_per_cell` blocks) belongs
    /// to this shard: the cells' blocks are numbered one after the other and
    /// dealt round robin, `global % count == index`.
    pub fn owns(&self, cell: usize, blocks_per_cell: u64, block: u64) -> bool {
        (cell as u64 * blocks_per_cell + block) % self.count == self.index
    }
}

impl std::str::FromStr for ShardMeta {
    type Err = String;
    /// Parses `K/N` (0 ≤ K < N).
    fn from_str(s: &str) -> Result<Self, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("'{s}' is not K/N"))?;
        let index: u64 = k
            .trim()
            .parse()
            .map_err(|_| format!("'{k}' is not a shard index"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("'{n}' is not a shard count"))?;
        if count == 0 || index >= count {
            return Err(format!("shard {index}/{count}: need 0 <= K < N"));
        }
        if count > crate::limits::MAX_SHARDS {
            return Err(format!(
                "shard {index}/{count}: at most {} shards (rwg's limit)",
                crate::limits::MAX_SHARDS
            ));
        }
        Ok(ShardMeta { index, count })
    }
}

/// The weight distribution of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeightsMeta {
    /// `normal` (scale = standard deviation) or `uniform` (scale = a for U(-a, a)).
    pub distribution: String,
    /// The distribution's scale.
    pub scale: f64,
}

/// Which cell: an environment × architecture × bias setting, and the
/// directory that holds it. Written flat into `run.json`, `cell.json` and
/// `stats.json` (as the first fields of a cell), and passed by reference
/// wherever a cell is named.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct CellId {
    /// Directory of the cell under `cells/` ([`cell_dir_name`]).
    pub dir: String,
    /// Environment id.
    pub env: String,
    /// Architecture name from the manifest (e.g. `0HL`, `1HL-4`).
    pub arch: String,
    /// Hidden layer sizes.
    pub hidden: Vec<usize>,
    /// Whether the networks have bias inputs.
    pub bias: bool,
}

impl CellId {
    /// The cell of env `env`, architecture `arch` (named `arch`, with hidden
    /// layers `hidden`) and bias setting `bias`, in its usual directory.
    pub fn new(env: &str, arch: &str, hidden: &[usize], bias: bool) -> CellId {
        CellId {
            dir: cell_dir_name(env, arch, bias),
            env: env.to_string(),
            arch: arch.to_string(),
            hidden: hidden.to_vec(),
            bias,
        }
    }

    /// Whether this is the cell of `env`, architecture name `arch` and `bias`.
    pub fn is(&self, env: &str, arch: &str, bias: bool) -> bool {
        self.env == env && self.arch == arch && self.bias == bias
    }
}

/// One cell: an environment × architecture × bias setting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellMeta {
    /// Which cell.
    #[serde(flatten)]
    pub id: CellId,
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
    /// With the manifest's `non_finite = "end"` for the cell's env: how
    /// many of its episodes a value that was not finite ended (flagged in
    /// its `scores.csv`). Absent with the default, `stop`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub non_finite_episodes: Option<u64>,
}

impl CellMeta {
    /// The rows of the cell's score files: its episodes per network, and
    /// the `non_finite` flag when it has `non_finite = "end"`.
    pub fn rows(&self) -> crate::rundir::rows::CellRows {
        crate::rundir::rows::CellRows {
            episodes: self.episodes,
            flagged: self.non_finite_episodes.is_some(),
        }
    }
}

pub use crate::rundir::names::cell_dir_name;

/// Writes `run.json` into run directory `out`, atomically.
pub fn write_run_meta(out: &Path, meta: &RunMeta) -> Result<(), StudyError> {
    let p = out.join(RUN_JSON);
    let json = serde_json::to_string_pretty(meta).map_err(|source| StudyError::Json {
        context: format!("cannot write {}", p.display()),
        source,
    })?;
    crate::rundir::export::write_atomic(&p, json.as_bytes())
        .map_err(StudyError::io(format!("cannot write {}", p.display())))
}

/// Why a JSON file of the run directory could not be read.
#[derive(Debug)]
#[non_exhaustive]
pub enum JsonFileError {
    /// The file could not be read.
    Io(std::io::Error),
    /// It is not the JSON expected.
    Json(serde_json::Error),
}

/// Reads and parses `run.json` (`RunMeta`) or `cell.json` (`CellMeta`): the
/// one reader of the run directory's JSON files.
pub fn load_json<T: serde::de::DeserializeOwned>(p: &Path) -> Result<T, JsonFileError> {
    let text = crate::limits::read_own_text(p, crate::limits::MAX_JSON_BYTES)
        .map_err(JsonFileError::Io)?;
    serde_json::from_str(&text).map_err(JsonFileError::Json)
}

/// Reads `run.json` of run directory `dir` (a file that does not parse is
/// an error that says how to rebuild it).
pub fn read_run_meta(dir: &Path) -> Result<RunMeta, StudyError> {
    read_json(&dir.join(RUN_JSON), RUN_JSON).map_err(|e| match e {
        StudyError::Json { source, .. } => StudyError::Json {
            context: crate::rundir::study::damaged_run_json(dir),
            source,
        },
        e => e,
    })
}

/// Reads a finished cell's `cell.json` in cell directory `dir`.
pub fn read_cell_meta(dir: &Path) -> Result<CellMeta, StudyError> {
    read_json(&dir.join(CELL_JSON), CELL_JSON)
}

fn read_json<T: serde::de::DeserializeOwned>(p: &Path, what: &str) -> Result<T, StudyError> {
    load_json(p).map_err(|e| match e {
        JsonFileError::Io(source) => StudyError::Io {
            context: format!("cannot read {}", p.display()),
            source,
        },
        JsonFileError::Json(source) => StudyError::Json {
            context: format!("{} is not an rwg {what}", p.display()),
            source,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_deal_blocks_round_robin_and_cover_everything_once() {
        let shards: Vec<ShardMeta> = (0..3).map(|k| format!("{k}/3").parse().unwrap()).collect();
        for cell in 0..4 {
            for b in 0..5 {
                assert_eq!(shards.iter().filter(|s| s.owns(cell, 5, b)).count(), 1);
            }
        }
        assert!("3/3".parse::<ShardMeta>().is_err());
        assert!("1".parse::<ShardMeta>().is_err());
    }
}
