//! Reading a cell's files against the checksums recorded when they were
//! written ([`crate::rundir::checksum`]): a file that does not match is an
//! error naming it and, where reading it shows one, the row.

use super::{
    check_samples_csv, read_cell_scores, read_samples_csv, CellData, Run, RunReadError, SampleRow,
    ScoreRows,
};
use crate::rundir::checksum;
use crate::rundir::error::RunDirError;
use crate::rundir::meta::CellMeta;
use crate::rundir::{SAMPLES_CSV, SCORES_CSV};
use std::path::Path;

impl Run {
    /// Checks `dir/name` against the cell's `SHA256SUMS` (nothing for a run
    /// written before checksums).
    fn check_file(&self, dir: &Path, name: &str) -> Result<(), RunDirError> {
        if !self.verified {
            return Ok(());
        }
        checksum::verify_file(dir, name, &checksum::recorded(dir, name)?)
    }

    /// Reads the cell's `scores.csv` in `dir`, checked against its checksum.
    /// A file that does not match is an error naming it, with the first bad
    /// row when it does not parse, or else the first sample whose statistics
    /// no longer match an intact `samples.csv`.
    pub(super) fn read_scores_verified(
        &self,
        cell: &CellMeta,
        dir: &Path,
    ) -> Result<ScoreRows, RunReadError> {
        let episodes = cell.episodes as usize;
        let spath = dir.join(SCORES_CSV);
        match (
            self.check_file(dir, SCORES_CSV),
            read_cell_scores(&spath, cell.rows()),
        ) {
            (Ok(()), parsed) => parsed,
            (Err(check), Err(row)) => Err(RunReadError::Damaged {
                check,
                row: Box::new(row),
            }),
            (Err(check), Ok(read)) => {
                let samples = dir.join(SAMPLES_CSV);
                let whole = read.scores.len() % episodes == 0;
                if whole && self.check_file(dir, SAMPLES_CSV).is_ok() {
                    let mut data = CellData::new(cell.clone(), episodes, read.scores, read.steps);
                    if cell.non_finite_episodes.is_some() {
                        data = data.with_non_finite(&read.cut);
                    }
                    if let Err(RunReadError::Csv { line, .. }) = check_samples_csv(&samples, &data)
                    {
                        let i = line.saturating_sub(2);
                        let (first, last) = (2 + i * episodes, 1 + (i + 1) * episodes);
                        let row = RunReadError::Csv {
                            path: spath,
                            line: first,
                            message: format!(
                                "sample {i} (rows {first}-{last}) no longer gives the statistics \
                                 samples.csv recorded for it"
                            ),
                        };
                        return Err(RunReadError::Damaged {
                            check,
                            row: Box::new(row),
                        });
                    }
                }
                Err(check.into())
            }
        }
    }

    /// Checks the cell's `samples.csv` in `dir` against its checksum and
    /// against the statistics of the scores in `data`.
    pub(super) fn check_samples_verified(
        &self,
        dir: &Path,
        data: &CellData,
    ) -> Result<(), RunReadError> {
        let path = dir.join(SAMPLES_CSV);
        match (
            self.check_file(dir, SAMPLES_CSV),
            check_samples_csv(&path, data),
        ) {
            (Ok(()), r) => r,
            (Err(check), Err(row)) => Err(RunReadError::Damaged {
                check,
                row: Box::new(row),
            }),
            (Err(check), Ok(())) => Err(check.into()),
        }
    }

    /// Reads one cell's `samples.csv` alone (checked against its checksum,
    /// and every mean, min and max finite, as finite scores give).
    pub fn load_samples(&self, cell: &CellMeta) -> Result<Vec<SampleRow>, RunReadError> {
        let path = self.cell_dir(cell).join(SAMPLES_CSV);
        let rows = self.load_samples_unchecked(cell)?;
        for (i, r) in rows.iter().enumerate() {
            let s = &r.stats;
            if let Some((what, x)) = [("mean", s.mean), ("min", s.min), ("max", s.max)]
                .into_iter()
                .find(|(_, x)| !x.is_finite())
            {
                return Err(RunReadError::Csv {
                    path,
                    line: i + 2,
                    message: format!(
                        "{what} {x} is not a finite number (a sample's statistics come from \
                         finite episode scores)"
                    ),
                });
            }
        }
        Ok(rows)
    }

    fn load_samples_unchecked(&self, cell: &CellMeta) -> Result<Vec<SampleRow>, RunReadError> {
        let dir = self.cell_dir(cell);
        let path = dir.join(SAMPLES_CSV);
        if self.verified {
            let check = checksum::recorded(&dir, SAMPLES_CSV)
                .and_then(|d| checksum::verify_file(&dir, SAMPLES_CSV, &d));
            if let Err(check) = check {
                return Err(match read_samples_csv(&path) {
                    Err(row) => RunReadError::Damaged {
                        check,
                        row: Box::new(row),
                    },
                    Ok(_) => check.into(),
                });
            }
        }
        read_samples_csv(&path)
    }
}
