//! Whether a run's statistics files (`stats.json`, `stats.csv`) were written
//! for the run its `run.json` records: they are derived, not checksummed,
//! and `rwg.load` reads `stats.csv` as it is, so one left from another study
//! or an earlier run in the folder must not pass for this run's.

use crate::rundir::meta::RunMeta;
use crate::rundir::{STATS_CSV, STATS_JSON};
use crate::shell::sh_path;
use std::path::Path;

/// What decides a run's statistics: the seed, samples and episodes of the
/// study (`None` where the file does not record them) and each cell's
/// folder, samples and episodes. Two runs that agree on it have the same
/// statistics (rwg is deterministic), so times are left out.
#[derive(Debug, PartialEq)]
struct Identity {
    study: Option<(u64, u64, u32)>,
    cells: Vec<(String, u64, u32)>,
}

impl Identity {
    fn of(meta: &RunMeta) -> Identity {
        Identity {
            study: Some((meta.seed, meta.samples, meta.episodes)),
            cells: meta
                .cells
                .iter()
                .map(|c| (c.id.dir.clone(), c.samples, c.episodes))
                .collect(),
        }
    }
}

/// What `stats.json` records of its run, if it reads.
fn json_identity(text: &str) -> Result<Identity, String> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let run: RunMeta = serde_json::from_value(v["run"].clone()).map_err(|e| e.to_string())?;
    Ok(Identity::of(&run))
}

/// What `stats.csv` records of its run's cells, if it reads.
fn csv_identity(text: &str) -> Result<Identity, String> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let header = r.headers().map_err(|e| e.to_string())?.clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or(format!("no column {name}"))
    };
    let (dir, samples, episodes) = (col("dir")?, col("samples")?, col("episodes")?);
    let mut cells = vec![];
    for (i, rec) in r.records().enumerate() {
        let bad = || format!("row {}: unreadable", i + 2);
        let rec = rec.map_err(|_| bad())?;
        let field = |k: usize| rec.get(k).unwrap_or("");
        cells.push((
            field(dir).to_string(),
            field(samples).parse().map_err(|_| bad())?,
            field(episodes).parse().map_err(|_| bad())?,
        ));
    }
    Ok(Identity { study: None, cells })
}

/// How a statistics file's text tells its run's [`Identity`].
type ReadIdentity = fn(&str) -> Result<Identity, String>;

/// One problem per statistics file of the run in `dir` (whose `run.json`
/// is `meta`) that is not this run's: written for another run, or
/// unreadable; each says how to write it again.
pub fn check_stats_files(dir: &Path, meta: &RunMeta) -> Vec<String> {
    let mut problems = vec![];
    let want = Identity::of(meta);
    let checks: [(&str, ReadIdentity); 2] =
        [(STATS_JSON, json_identity), (STATS_CSV, csv_identity)];
    for (name, identity) in checks {
        let path = dir.join(name);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue; // none (or unreadable: the readers say so)
        };
        let matches = identity(&text).map(|got| match got.study {
            Some(_) => got == want,
            None => got.cells == want.cells,
        });
        let why = match matches {
            Ok(true) => continue,
            Ok(false) => "written for another run than run.json records (another study, an \
                          earlier run in this folder, or this run before it finished)"
                .to_string(),
            Err(e) => format!("not readable as rwg writes it ({e})"),
        };
        problems.push(format!(
            "{}: {why}; `rwg stats {}` writes the statistics of this run again",
            path.display(),
            sh_path(dir)
        ));
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_csv_names_its_cells_by_column_whatever_the_quoting() {
        let text = "env,dir,samples,episodes\n\"a,b\",c0,10,3\n";
        let got = csv_identity(text).unwrap();
        assert_eq!(got.cells, vec![("c0".to_string(), 10, 3)]);
        assert!(csv_identity("dir,samples\nc0,1\n")
            .unwrap_err()
            .contains("episodes"));
        assert!(csv_identity("dir,samples,episodes\nc0,x,1\n")
            .unwrap_err()
            .contains("row 2"));
    }
}
