//! What a run records of how its JAX cells computed (each cell's
//! `env.json`): the device, the precisions, the program's lanes and the
//! library versions; shown by `report.html`, `rwg stats` and
//! `rwg status`.

use crate::table_render::{Cell, Table};
use rwg_study::rundir::env_record::{read_record, JaxRecord};
use std::path::Path;

/// The cells of one env that computed alike.
#[derive(Debug, Clone, PartialEq)]
pub struct JaxSetting {
    /// The env id.
    pub env: String,
    /// The cells' directory names.
    pub cells: Vec<String>,
    /// What their `env.json` records.
    pub record: JaxRecord,
}

/// The JAX settings of the cells `dirs` of the run in `run_dir` (cell
/// directory names under `cells/`), one per env and setting in order of
/// first appearance. A cell without an `env.json` (not started), whose
/// `env.json` cannot be read or that is no JAX env is left out.
pub fn jax_settings<'a>(
    run_dir: &Path,
    dirs: impl IntoIterator<Item = &'a str>,
) -> Vec<JaxSetting> {
    let mut out: Vec<JaxSetting> = Vec::new();
    for dir in dirs {
        let Ok(Some(rec)) = read_record(&run_dir.join("cells").join(dir)) else {
            continue;
        };
        let Some(jax) = rec.jax else { continue };
        match out.iter_mut().find(|s| s.env == rec.env && s.record == jax) {
            Some(s) => s.cells.push(dir.to_string()),
            None => out.push(JaxSetting {
                env: rec.env,
                cells: vec![dir.to_string()],
                record: jax,
            }),
        }
    }
    out
}

/// The device: its kind, and JAX's platform when the kind does not say it
/// (`cpu`, `NVIDIA H200 (gpu)`).
pub fn device_text(r: &JaxRecord) -> String {
    if r.device_kind.eq_ignore_ascii_case(&r.platform) {
        r.device_kind.clone()
    } else {
        format!("{} ({})", r.device_kind, r.platform)
    }
}

/// The versions: JAX's and jaxlib's first, then the env's library, then
/// Python (`jax 0.10.2, jaxlib 0.10.2, gymnax 1.0.1, Python 3.11.7`).
pub fn versions_text(r: &JaxRecord) -> String {
    let rank = |k: &str| match k {
        "jax" => 0,
        "jaxlib" => 1,
        "python" => 3,
        _ => 2,
    };
    let mut v: Vec<(&String, &String)> = r.versions.iter().collect();
    v.sort_by_key(|(k, _)| rank(k));
    let parts: Vec<String> = v
        .into_iter()
        .map(|(k, ver)| {
            let name = if k == "python" { "Python" } else { k };
            format!("{name} {ver}")
        })
        .collect();
    parts.join(", ")
}

/// The choices recorded when the env was made: how a discrete action is
/// chosen where the family gives legal actions, then the family's settings
/// (`argmax over legal actions, impl = jax`); empty when there are none.
pub fn choices_text(r: &JaxRecord) -> String {
    let mask = match r.action_mask.as_deref() {
        Some("legal") => Some("argmax over legal actions".to_string()),
        Some("off") => Some("plain argmax (action_mask = false)".to_string()),
        _ => None,
    };
    let settings = r.settings.iter().map(|(k, v)| format!("{k} = {v}"));
    mask.into_iter()
        .chain(settings)
        .collect::<Vec<_>>()
        .join(", ")
}

/// One line per setting: `gymnax:CartPole-v1 (3 cells): cpu, float32,
/// matmul highest, 512 lanes; jax 0.10.2, ...`, and the choices made when the env
/// was made, if any (`; argmax over legal actions`).
pub fn setting_line(s: &JaxSetting) -> String {
    let choices = choices_text(&s.record);
    format!(
        "{} ({} cell{}): {}, {}, matmul {}, {} lanes; {}{}{}",
        s.env,
        s.cells.len(),
        if s.cells.len() == 1 { "" } else { "s" },
        device_text(&s.record),
        s.record.precision,
        s.record.matmul_precision,
        s.record.lanes,
        versions_text(&s.record),
        if choices.is_empty() { "" } else { "; " },
        choices
    )
}

/// The settings as a table, one row each.
pub fn jax_table(settings: &[JaxSetting]) -> Table {
    let header = [
        "env",
        "cells",
        "device",
        "precision",
        "matmul precision",
        "lanes",
        "versions",
        "choices",
    ]
    .into_iter()
    .map(Cell::from)
    .collect();
    let rows = settings
        .iter()
        .map(|s| {
            vec![
                Cell::plain(s.env.clone()),
                Cell::plain(s.cells.len().to_string()),
                Cell::plain(device_text(&s.record)),
                Cell::plain(s.record.precision.clone()),
                Cell::plain(s.record.matmul_precision.clone()),
                Cell::plain(s.record.lanes.to_string()),
                Cell::plain(versions_text(&s.record)),
                Cell::plain(match choices_text(&s.record) {
                    c if c.is_empty() => "-".to_string(),
                    c => c,
                }),
            ]
        })
        .collect();
    Table {
        title: "How the JAX envs computed (each cell's env.json)".into(),
        header,
        rows,
        notes: vec![],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn record(kind: &str, platform: &str) -> JaxRecord {
        let versions: BTreeMap<String, String> = [
            ("python", "3.11.7"),
            ("gymnax", "1.0.1"),
            ("jaxlib", "0.10.2"),
            ("jax", "0.10.2"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        JaxRecord {
            observation_space: String::new(),
            action_space: String::new(),
            versions,
            device_kind: kind.into(),
            platform: platform.into(),
            precision: "float32".into(),
            matmul_precision: "highest".into(),
            lanes: 512,
            refill: 128,
            episode_loop: None,
            source: None,
            observation_leaves: vec![],
            action_mask: None,
            settings: BTreeMap::new(),
        }
    }

    #[test]
    fn choices_name_the_mask_and_the_family_settings() {
        let mut r = record("cpu", "cpu");
        assert_eq!(choices_text(&r), "");
        r.action_mask = Some("none".into());
        assert_eq!(choices_text(&r), "");
        r.action_mask = Some("legal".into());
        r.settings.insert("impl".into(), "jax".into());
        assert_eq!(choices_text(&r), "argmax over legal actions, impl = jax");
        r.action_mask = Some("off".into());
        let s = JaxSetting {
            env: "pgx:2048".into(),
            cells: vec!["a".into()],
            record: r,
        };
        assert!(setting_line(&s)
            .ends_with("Python 3.11.7; plain argmax (action_mask = false), impl = jax"));
    }

    #[test]
    fn texts_name_device_precisions_lanes_and_versions() {
        let s = JaxSetting {
            env: "gymnax:CartPole-v1".into(),
            cells: vec!["a".into(), "b".into()],
            record: record("cpu", "cpu"),
        };
        assert_eq!(
            setting_line(&s),
            "gymnax:CartPole-v1 (2 cells): cpu, float32, matmul highest, 512 lanes; \
             jax 0.10.2, jaxlib 0.10.2, gymnax 1.0.1, Python 3.11.7"
        );
        assert_eq!(
            device_text(&record("NVIDIA H200", "gpu")),
            "NVIDIA H200 (gpu)"
        );
        let t = jax_table(&[s]);
        assert_eq!(t.rows[0][2].text, "cpu");
        assert_eq!(t.rows[0][4].text, "highest");
        assert_eq!(t.rows[0][5].text, "512");
    }

    #[test]
    fn cells_of_one_setting_are_one_entry_and_other_cells_are_left_out() {
        use rwg_study::rundir::env_record::{write_record, EnvRecord};
        let dir = std::env::temp_dir().join(format!("rwg-jax-cells-{}", std::process::id()));
        let plain = EnvRecord {
            env: "CartPole-v1".into(),
            observation_space: String::new(),
            action_space: "Discrete(2)".into(),
            max_episode_steps: Some(500),
            reward_threshold: None,
            gymnasium: None,
            jax: None,
        };
        let mut rec = plain.clone().with_jax(record("cpu", "cpu"));
        rec.env = "gymnax:CartPole-v1".into();
        for c in ["a", "b", "c", "d"] {
            std::fs::create_dir_all(dir.join("cells").join(c)).unwrap();
        }
        write_record(&dir.join("cells/a"), &rec).unwrap();
        write_record(&dir.join("cells/b"), &rec).unwrap();
        let mut other = rec.clone();
        other.jax.as_mut().unwrap().precision = "float64".into();
        write_record(&dir.join("cells/c"), &other).unwrap();
        write_record(&dir.join("cells/d"), &plain).unwrap();
        let s = jax_settings(&dir, ["a", "d", "b", "c", "missing"]);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].cells, ["a", "b"]);
        assert_eq!(s[1].cells, ["c"]);
        assert_eq!(s[1].record.precision, "float64");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
