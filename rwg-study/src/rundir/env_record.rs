//! A cell's `env.json`: the environment as it was when the cell started
//! (its spaces, time limit and reward threshold, and for a Gymnasium env
//! Gymnasium's own text of its spaces and the workers' `PYTHONHASHSEED`; for
//! a JAX env the library's text of its spaces, the versions of JAX and the
//! env's library, the device's kind and platform, the precisions, the
//! episode loop (its lanes and when ended lanes refill), and for a `jax:` env
//! a digest of its module's source and the `PYTHONPATH` it was found through).
//! Every block of a cell must be computed under the same env, so a resume
//! or a merge compares the env as it is now with this record and is refused
//! when they differ, naming the difference (a new version of the env's
//! package, an environment variable the env reads).

use crate::rundir::export::write_atomic;
use crate::rundir::meta::{load_json, JsonFileError};
use crate::StudyError;
use rwg_env::{EnvSpec, Space};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The file's name in a cell's directory.
pub const ENV_JSON: &str = "env.json";

/// The contents of `env.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvRecord {
    /// The env's id.
    pub env: String,
    /// The observation space in rwg's terms (flattened): `Box(low [..], high [..])`.
    pub observation_space: String,
    /// The action space in rwg's terms: `Discrete(n)` or `Box(low [..], high [..])`.
    pub action_space: String,
    /// The time limit (`None`: none).
    pub max_episode_steps: Option<u32>,
    /// The env's reward threshold (`None`: none).
    pub reward_threshold: Option<f64>,
    /// For a Gymnasium env: what its workers reported.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gymnasium: Option<GymRecord>,
    /// For a JAX env: what its worker reported and how it computes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jax: Option<JaxRecord>,
}

/// What a JAX env's worker reported, in [`EnvRecord`]: every block of a
/// cell is computed by the same JAX, env library, kind of device,
/// precisions and lanes (the compiled program; how many networks a call
/// holds, or how many devices run it, changes no result).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JaxRecord {
    /// The library's text of the observation space.
    pub observation_space: String,
    /// The library's text of the action space.
    pub action_space: String,
    /// Versions: `python` (shown, not compared), `jax`, `jaxlib`, and
    /// `gymnax`, `brax` or `module` (compared).
    pub versions: BTreeMap<String, String>,
    /// The device's kind (`cpu`, `NVIDIA H200`).
    pub device_kind: String,
    /// JAX's platform (`cpu`, `gpu`, `tpu`).
    pub platform: String,
    /// `float32` or `float64`.
    pub precision: String,
    /// The precision of matrix products (`highest`, `high`, `default`).
    pub matmul_precision: String,
    /// The episode loop: `lanes` episodes at once, a lane whose episode
    /// ended taking the next one; compared.
    pub lanes: u32,
    /// Ended lanes that wait to refill together (shown, not compared: it
    /// changes the speed, not the results).
    pub refill: u32,
    /// Which program ran the episodes (`lanes`, or `plain` for an env whose
    /// episodes all end at the same step) and why; shown, not compared (the
    /// same bits either way); absent in older records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episode_loop: Option<rwg_jax::protocol::EpisodeLoop>,
    /// For a `jax:module:callable` env: a digest of its module's source
    /// (compared) and where it was imported from (not compared).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<rwg_jax::protocol::ModuleSource>,
    /// The observation's leaves (name, shape, dtype) in the order they are
    /// flattened into the networks' inputs (empty in records written before
    /// rwg recorded them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub observation_leaves: Vec<rwg_jax::protocol::Leaf>,
    /// How a discrete action is chosen: `legal` (argmax over the legal
    /// actions the family gives, an extension of the paper's policy), `off`
    /// (plain argmax, the manifest's choice), `none` (the family gives no
    /// legal actions, or the actions are a box); absent in older records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_mask: Option<String>,
    /// Choices made when the env was made (Playground's physics `impl`,
    /// Craftax's `auto_reset`, Pgx's game version).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub settings: BTreeMap<String, String>,
}

/// The version key shown in a record but not compared.
const SHOWN_VERSION: &str = "python";

impl JaxRecord {
    /// What differs between this record (then) and `now`, each as
    /// `(what, then, now)`.
    fn differences(&self, now: &JaxRecord) -> Vec<(String, String, String)> {
        let mut out = vec![];
        let mut differ = |what: &str, then: &str, now: &str| {
            if then != now {
                out.push((what.to_string(), then.to_string(), now.to_string()));
            }
        };
        differ(
            "observation space",
            &self.observation_space,
            &now.observation_space,
        );
        differ("action space", &self.action_space, &now.action_space);
        let mut keys: Vec<&String> = self.versions.keys().chain(now.versions.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys.into_iter().filter(|k| *k != SHOWN_VERSION) {
            let get = |v: &BTreeMap<String, String>| v.get(k).cloned().unwrap_or("none".into());
            differ(k, &get(&self.versions), &get(&now.versions));
        }
        differ("device kind", &self.device_kind, &now.device_kind);
        differ("platform", &self.platform, &now.platform);
        differ("precision", &self.precision, &now.precision);
        differ(
            "matmul precision",
            &self.matmul_precision,
            &now.matmul_precision,
        );
        differ("lanes", &self.lanes.to_string(), &now.lanes.to_string());
        let code = |s: &Option<rwg_jax::protocol::ModuleSource>| {
            s.as_ref().map_or("none".to_string(), |s| {
                format!("SHA-256 {} of {} file(s)", s.sha256, s.files)
            })
        };
        if code(&self.source) != code(&now.source) {
            let module = self.source.as_ref().or(now.source.as_ref());
            let what = module.map_or(String::new(), |s| format!(" {}", s.module));
            differ(
                &format!("the source of module{what} (edited since the cell started?)"),
                &code(&self.source),
                &code(&now.source),
            );
        }
        // (what an older record lacks is not compared)
        if !self.observation_leaves.is_empty() {
            let text = |r: &JaxRecord| format!("{:?}", r.observation_leaves);
            differ("observation leaves", &text(self), &text(now));
        }
        if let (Some(then), Some(n)) = (&self.action_mask, &now.action_mask) {
            differ("action mask", then, n);
        }
        let mut keys: Vec<&String> = self.settings.keys().chain(now.settings.keys()).collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let get = |v: &BTreeMap<String, String>| v.get(k).cloned().unwrap_or("none".into());
            differ(k, &get(&self.settings), &get(&now.settings));
        }
        out
    }

    /// The versions as a message shows them (`jax 0.10.2, gymnax 1.0.1, Python 3.11.7`).
    fn versions_text(&self) -> String {
        let mut parts: Vec<String> = self
            .versions
            .iter()
            .filter(|(k, _)| *k != SHOWN_VERSION)
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        if let Some(p) = self.versions.get(SHOWN_VERSION) {
            parts.push(format!("Python {p}"));
        }
        parts.join(", ")
    }
}

/// What a Gymnasium env's workers reported, in [`EnvRecord`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GymRecord {
    /// Gymnasium's text of the observation space.
    pub observation_space: String,
    /// Gymnasium's text of the action space.
    pub action_space: String,
    /// The workers' `PYTHONHASHSEED` (rwg's default unless the user set it).
    pub python_hash_seed: String,
    /// Gymnasium's version (shown, not compared).
    pub gymnasium_version: String,
    /// Python's version (shown, not compared).
    pub python_version: String,
}

/// A space in the record's words.
fn space_text(s: &Space) -> String {
    match s {
        Space::Discrete { n } => format!("Discrete({n})"),
        Space::Box(b) => format!("Box(low {:?}, high {:?})", b.low, b.high),
    }
}

impl EnvRecord {
    /// The record of an env described by `spec` (and `gymnasium`, for a
    /// Gymnasium env; [`EnvRecord::with_jax`] adds a JAX env's).
    pub fn new(spec: &EnvSpec, gymnasium: Option<GymRecord>) -> EnvRecord {
        EnvRecord {
            env: spec.id.clone(),
            observation_space: space_text(&spec.observation_space),
            action_space: space_text(&spec.action_space),
            max_episode_steps: spec.max_episode_steps,
            reward_threshold: spec.reward_threshold,
            gymnasium,
            jax: None,
        }
    }

    /// This record with a JAX env's part.
    pub fn with_jax(mut self, jax: JaxRecord) -> EnvRecord {
        self.jax = Some(jax);
        self
    }

    /// What differs between this record (then) and `now`, one entry each:
    /// `what: X then, Y now` (empty: the same env). Versions are not
    /// compared: only what the episodes are computed under.
    pub fn differences(&self, now: &EnvRecord) -> Vec<String> {
        let mut out = vec![];
        let mut differ = |what: &str, then: String, now: String| {
            if then != now {
                out.push(format!("{what}: {then} then, {now} now"));
            }
        };
        let opt = |v: Option<String>| v.unwrap_or_else(|| "none".into());
        if let (Some(a), Some(b)) = (&self.gymnasium, &now.gymnasium) {
            differ(
                "observation space",
                a.observation_space.clone(),
                b.observation_space.clone(),
            );
            differ(
                "action space",
                a.action_space.clone(),
                b.action_space.clone(),
            );
            differ(
                "PYTHONHASHSEED",
                a.python_hash_seed.clone(),
                b.python_hash_seed.clone(),
            );
        }
        match (&self.jax, &now.jax) {
            (Some(a), Some(b)) => {
                for (what, then, now) in a.differences(b) {
                    differ(&what, then, now);
                }
            }
            (None, Some(_)) => differ("JAX worker", "none".into(), "one".into()),
            (Some(_), None) => differ("JAX worker", "one".into(), "none".into()),
            (None, None) => {}
        }
        differ(
            "flat observation space",
            self.observation_space.clone(),
            now.observation_space.clone(),
        );
        differ(
            "action bounds",
            self.action_space.clone(),
            now.action_space.clone(),
        );
        differ(
            "time limit",
            opt(self.max_episode_steps.map(|s| format!("{s} steps"))),
            opt(now.max_episode_steps.map(|s| format!("{s} steps"))),
        );
        differ(
            "reward threshold",
            opt(self.reward_threshold.map(|t| t.to_string())),
            opt(now.reward_threshold.map(|t| t.to_string())),
        );
        out
    }

    /// Versions, for a refusal's message (`Gymnasium 1.4.0, Python 3.11.2`).
    fn versions(&self) -> String {
        if let Some(j) = &self.jax {
            return format!(" ({})", j.versions_text());
        }
        self.gymnasium.as_ref().map_or(String::new(), |g| {
            format!(
                " (Gymnasium {}, Python {})",
                g.gymnasium_version, g.python_version
            )
        })
    }
}

/// The `PYTHONPATH` the envs of run directory `run` were imported through
/// (the first a cell's `env.json` records for a `jax:module:callable`
/// env), if any: what a printed command that starts them again needs.
pub fn recorded_pythonpath(run: &Path) -> Option<String> {
    let cells = std::fs::read_dir(run.join(crate::rundir::CELLS)).ok()?;
    let mut dirs: Vec<_> = cells.flatten().map(|e| e.path()).collect();
    dirs.sort();
    dirs.iter().find_map(|d| cell_pythonpath(d))
}

/// The `PYTHONPATH` cell directory `dir`'s `env.json` records, if any.
pub fn cell_pythonpath(dir: &Path) -> Option<String> {
    read_record(dir).ok()??.jax?.source?.pythonpath
}

/// Reads the record in cell directory `dir`, if there is one.
pub fn read_record(dir: &Path) -> Result<Option<EnvRecord>, StudyError> {
    let p = dir.join(ENV_JSON);
    match load_json::<EnvRecord>(&p) {
        Ok(r) => Ok(Some(r)),
        Err(JsonFileError::Io(e)) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(JsonFileError::Io(source)) => Err(StudyError::Io {
            context: format!("cannot read {}", p.display()),
            source,
        }),
        Err(JsonFileError::Json(source)) => Err(StudyError::Json {
            context: format!(
                "{} is not an rwg {ENV_JSON} (the env a cell started with); delete it if \
                 the cell holds no blocks yet, else the cell directory, to compute the cell again",
                p.display()
            ),
            source,
        }),
    }
}

/// Writes `record` into cell directory `dir` (created if needed), atomically.
pub fn write_record(dir: &Path, record: &EnvRecord) -> Result<(), StudyError> {
    let p = dir.join(ENV_JSON);
    crate::rundir::export::create_dir_in(dir)
        .map_err(StudyError::io(format!("cannot create {}", dir.display())))?;
    let json = serde_json::to_string_pretty(record).expect("serialisable") + "\n";
    write_atomic(&p, json.as_bytes())
        .map_err(StudyError::io(format!("cannot write {}", p.display())))
}

/// Checks that the record in cell directory `dir`, if any, describes the
/// env `now` describes; `what` says what was refused and what to do ("the
/// resume ...; ..."). `Ok(true)`: there is a record and it matches,
/// `Ok(false)`: there is none.
pub fn check_record(dir: &Path, now: &EnvRecord, what: &str) -> Result<bool, StudyError> {
    let Some(then) = read_record(dir)? else {
        return Ok(false);
    };
    let diffs = then.differences(now);
    if diffs.is_empty() {
        return Ok(true);
    }
    Err(StudyError::Refused(format!(
        "{} records the env '{}' as cell {} started{}, and it is another now{}: {}; {what}",
        dir.join(ENV_JSON).display(),
        then.env,
        dir.file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
        then.versions(),
        if now.versions() == then.versions() {
            String::new()
        } else {
            now.versions()
        },
        diffs.join("; ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_env::BoxSpace;

    fn spec(high: f64, limit: Option<u32>) -> EnvSpec {
        EnvSpec {
            id: "gymnasium:X-v0".into(),
            observation_space: Space::Box(BoxSpace::new(
                vec![f64::NEG_INFINITY],
                vec![f64::INFINITY],
            )),
            action_space: Space::Box(BoxSpace::symmetric(&[high])),
            max_episode_steps: limit,
            reward_threshold: None,
        }
    }

    fn gym(action: &str, seed: &str) -> Option<GymRecord> {
        Some(GymRecord {
            observation_space: "Box(-inf, inf, (1,), float64)".into(),
            action_space: action.into(),
            python_hash_seed: seed.into(),
            gymnasium_version: "1.4.0".into(),
            python_version: "3.11.2".into(),
        })
    }

    #[test]
    fn a_record_round_trips_and_names_every_difference() {
        let dir = std::env::temp_dir().join(format!("rwg-env-record-{}", std::process::id()));
        let then = EnvRecord::new(&spec(1.0, Some(60)), gym("Box(-1.0, 1.0)", "0"));
        assert!(
            !check_record(&dir, &then, "refused").unwrap(),
            "no record yet"
        );
        write_record(&dir, &then).unwrap();
        assert_eq!(read_record(&dir).unwrap().as_ref(), Some(&then));
        assert!(check_record(&dir, &then, "refused").unwrap());
        // a new version alone is no difference
        let mut newer = then.clone();
        newer.gymnasium.as_mut().unwrap().gymnasium_version = "1.5.0".into();
        assert!(check_record(&dir, &newer, "refused").unwrap());
        let now = EnvRecord::new(&spec(100.0, None), gym("Box(-100.0, 100.0)", "7"));
        let err = check_record(&dir, &now, "do this").unwrap_err().to_string();
        for s in [
            "env.json records the env 'gymnasium:X-v0'",
            "action space: Box(-1.0, 1.0) then, Box(-100.0, 100.0) now",
            "PYTHONHASHSEED: 0 then, 7 now",
            "action bounds: Box(low [-1.0], high [1.0]) then, Box(low [-100.0], high [100.0]) now",
            "time limit: 60 steps then, none now",
            "(Gymnasium 1.4.0, Python 3.11.2)",
            "; do this",
        ] {
            assert!(err.contains(s), "{s:?} missing in {err}");
        }
        assert!(!err.contains("observation space:"), "{err}");
        std::fs::write(dir.join(ENV_JSON), "{").unwrap();
        let err = read_record(&dir).unwrap_err().to_string();
        assert!(err.contains("is not an rwg env.json"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn jax(jax: &str, python: &str, kind: &str) -> JaxRecord {
        JaxRecord {
            observation_space: "Box(-inf, inf, (1,), float32)".into(),
            action_space: "Box(-1.0, 1.0, (1,), float32)".into(),
            versions: [
                ("jax", jax),
                ("jaxlib", jax),
                ("gymnax", "1.0.1"),
                ("python", python),
            ]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
            device_kind: kind.into(),
            platform: "cpu".into(),
            precision: "float32".into(),
            matmul_precision: "highest".into(),
            lanes: 1024,
            refill: 128,
            episode_loop: Some(rwg_jax::protocol::EpisodeLoop {
                kind: "lanes".into(),
                why: "its episodes end on what the actions do".into(),
            }),
            source: None,
            observation_leaves: vec![rwg_jax::protocol::Leaf {
                name: "grid".into(),
                shape: vec![5, 5, 3],
                dtype: "uint8".into(),
            }],
            action_mask: Some("legal".into()),
            settings: [("impl".to_string(), "jax".to_string())].into(),
        }
    }

    #[test]
    fn a_jax_record_compares_versions_device_precisions_and_lanes() {
        let dir = std::env::temp_dir().join(format!("rwg-env-record-jax-{}", std::process::id()));
        let then =
            EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(jax("0.10.2", "3.11.7", "cpu"));
        write_record(&dir, &then).unwrap();
        assert_eq!(read_record(&dir).unwrap().as_ref(), Some(&then));
        // Python's version is shown, not compared
        let other_python =
            EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(jax("0.10.2", "3.12.1", "cpu"));
        assert!(check_record(&dir, &other_python, "refused").unwrap());
        // nor when ended lanes refill
        let mut other_refill = jax("0.10.2", "3.11.7", "cpu");
        other_refill.refill = 1;
        let other_refill = EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(other_refill);
        assert!(check_record(&dir, &other_refill, "refused").unwrap());
        // nor which program ran the episodes (the same bits), nor a record
        // that does not say
        for episode_loop in [
            None,
            Some(rwg_jax::protocol::EpisodeLoop {
                kind: "plain".into(),
                why: "every episode ends at the same step, whatever the actions".into(),
            }),
        ] {
            let mut other_loop = jax("0.10.2", "3.11.7", "cpu");
            other_loop.episode_loop = episode_loop;
            let other_loop = EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(other_loop);
            assert!(check_record(&dir, &other_loop, "refused").unwrap());
        }
        let mut now = jax("0.4.30", "3.11.7", "NVIDIA H200");
        now.precision = "float64".into();
        now.matmul_precision = "default".into();
        now.lanes = 65536;
        now.action_mask = Some("off".into());
        now.settings.insert("impl".into(), "warp".into());
        now.observation_leaves[0].dtype = "float32".into();
        let now = EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(now);
        let err = check_record(&dir, &now, "do this").unwrap_err().to_string();
        for s in [
            "jax: 0.10.2 then, 0.4.30 now",
            "jaxlib: 0.10.2 then, 0.4.30 now",
            "device kind: cpu then, NVIDIA H200 now",
            "precision: float32 then, float64 now",
            "matmul precision: highest then, default now",
            "lanes: 1024 then, 65536 now",
            "action mask: legal then, off now",
            "impl: jax then, warp now",
            "observation leaves: ",
            "(gymnax 1.0.1, jax 0.10.2, jaxlib 0.10.2, Python 3.11.7)",
        ] {
            assert!(err.contains(s), "{s:?} missing in {err}");
        }
        assert!(!err.contains("gymnax: "), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_jax_module_s_source_is_compared_not_where_it_was_found() {
        use rwg_jax::protocol::ModuleSource;
        let source = |sha: &str, pythonpath: &str| {
            let mut r = jax("0.10.2", "3.11.7", "cpu");
            r.source = Some(ModuleSource {
                module: "my_envs".into(),
                sha256: sha.into(),
                files: 2,
                pythonpath: Some(pythonpath.into()),
            });
            EnvRecord::new(&spec(1.0, Some(60)), None).with_jax(r)
        };
        let then = source("aa", "/home/me/envs");
        assert!(then.differences(&source("aa", "/elsewhere")).is_empty());
        assert_eq!(
            then.differences(&source("bb", "/home/me/envs")),
            [
                "the source of module my_envs (edited since the cell started?): SHA-256 aa of 2 \
              file(s) then, SHA-256 bb of 2 file(s) now"
            ]
        );
    }
}
