//! Reading a cell's CSV files (`scores.csv`, `samples.csv`), and checking
//! its `samples.csv` against the statistics of its scores.

use super::read_error::io_err;
use super::{CellData, RunReadError};
use crate::rundir::export::csv_reader;
use crate::rundir::rows;
use crate::rundir::rows::CellRows;
use crate::rundir::{SAMPLES_HEADER, SAMPLES_HEADER_FLAGGED, SCORES_HEADER, SCORES_HEADER_FLAGGED};
use crate::stats::{self, SampleStats};
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::Path;

/// One data record of a CSV file: a line of a plain file
/// ([`rows::is_plain`]), or a record of the `csv` reader.
#[derive(Clone, Copy)]
enum Record<'a> {
    Plain(&'a str),
    Csv(&'a csv::StringRecord),
}

/// The fields of one CSV record, checking the count.
fn fields<'a, const K: usize>(
    row: Record<'a>,
    path: &Path,
    lineno: usize,
) -> Result<[&'a str; K], RunReadError> {
    let got = match row {
        Record::Plain(line) => rows::split_fields::<K>(line),
        Record::Csv(r) if r.len() == K => {
            let mut out = [""; K];
            for (o, f) in out.iter_mut().zip(r) {
                *o = f;
            }
            Ok(out)
        }
        Record::Csv(r) => Err(r.len()),
    };
    got.map_err(|n| RunReadError::Csv {
        path: path.to_path_buf(),
        line: lineno,
        message: format!("expected {K} fields, found {n}"),
    })
}

fn parse<T: std::str::FromStr>(
    s: &str,
    what: &str,
    path: &Path,
    lineno: usize,
) -> Result<T, RunReadError> {
    s.parse().map_err(|_| RunReadError::Csv {
        path: path.to_path_buf(),
        line: lineno,
        message: format!("{what} {s:?} is not a valid number"),
    })
}

/// A CSV reading error: I/O, or malformed text with its line.
fn csv_error(path: &Path, e: csv::Error) -> RunReadError {
    let line = e.position().map_or(0, |p| p.line() as usize);
    match e.into_kind() {
        csv::ErrorKind::Io(e) => io_err(path)(e),
        other => RunReadError::Csv {
            path: path.to_path_buf(),
            line,
            message: format!("{other:?}"),
        },
    }
}

/// Reads a CSV file: checks the header is one of `headers`, then calls
/// `row` with each data record, its 1-based line number and the index of
/// its header in `headers`; `row` returns `false` to stop early.
/// A plain file (what rwg writes) is split by [`rows`]; any other goes
/// through the `csv` crate (fields trimmed, empty lines skipped, a BOM
/// allowed), which gives the same records for a plain one.
fn read_csv(
    path: &Path,
    headers: &[&str],
    mut row: impl FnMut(Record<'_>, usize, usize) -> Result<bool, RunReadError>,
) -> Result<(), RunReadError> {
    let header = headers.join("\" or \"");
    let empty = || RunReadError::Csv {
        path: path.to_path_buf(),
        line: 1,
        message: format!("empty file, expected header \"{header}\""),
    };
    let bad_header = |found: &str| RunReadError::Csv {
        path: path.to_path_buf(),
        line: 1,
        message: format!("header is {found:?}, expected \"{header}\""),
    };
    // One open file for the check and the read: a file renamed over `path`
    // in between cannot be read by the wrong path.
    let which = |found: &str| headers.iter().position(|h| *h == found);
    let mut file = crate::limits::open_regular(path).map_err(io_err(path))?;
    if rows::is_plain_reader(&mut file).map_err(io_err(path))? {
        let mut h = 0;
        file.seek(SeekFrom::Start(0)).map_err(io_err(path))?;
        let mut input = BufReader::with_capacity(1 << 16, file);
        let mut line = Vec::with_capacity(64);
        let mut lineno = 0;
        loop {
            line.clear();
            if input.read_until(b'\n', &mut line).map_err(io_err(path))? == 0 {
                return if lineno == 0 { Err(empty()) } else { Ok(()) };
            }
            lineno += 1;
            let text = line.strip_suffix(b"\n").unwrap_or(&line);
            // Plain text is ASCII; a file changed since the check is an error.
            let text = std::str::from_utf8(text).map_err(|_| RunReadError::Csv {
                path: path.to_path_buf(),
                line: lineno,
                message: "not UTF-8 text (the file changed while it was read?)".into(),
            })?;
            if lineno == 1 {
                h = which(text).ok_or_else(|| bad_header(text))?;
            } else if !row(Record::Plain(text), lineno, h)? {
                return Ok(());
            }
        }
    }
    file.seek(SeekFrom::Start(0)).map_err(io_err(path))?;
    let mut records = csv_reader(file, true).into_records();
    let first = match records.next() {
        None => return Err(empty()),
        Some(r) => r.map_err(|e| csv_error(path, e))?,
    };
    let found = first.iter().collect::<Vec<_>>().join(",");
    let h = which(found.trim_start_matches('\u{feff}')).ok_or_else(|| bad_header(&found))?;
    for r in records {
        let r = r.map_err(|e| csv_error(path, e))?;
        let lineno = r.position().map_or(0, |p| p.line() as usize);
        if !row(Record::Csv(&r), lineno, h)? {
            break;
        }
    }
    Ok(())
}

/// Reads a `scores.csv` (`sample,episode,score,steps`, rows ordered by
/// sample then episode, `episodes` rows per sample) into row-major score and
/// step vectors.
pub fn read_scores_csv(path: &Path, episodes: usize) -> Result<(Vec<f64>, Vec<u32>), RunReadError> {
    let rows = CellRows::from(u32::try_from(episodes).unwrap_or(u32::MAX));
    read_cell_scores(path, rows).map(|s| (s.scores, s.steps))
}

/// A cell's `scores.csv` as read.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScoreRows {
    /// Episode scores, row-major `N × E`.
    pub scores: Vec<f64>,
    /// Episode lengths, same layout.
    pub steps: Vec<u32>,
    /// With flagged rows: whether a value that was not finite ended each
    /// episode (same layout); else empty.
    pub cut: Vec<bool>,
}

/// Reads a cell's `scores.csv` of `rows` (its header: with the
/// `non_finite` column exactly when they are flagged), rows ordered by
/// sample then episode.
pub fn read_cell_scores(path: &Path, rows: CellRows) -> Result<ScoreRows, RunReadError> {
    let episodes = rows.episodes.max(1) as usize;
    let mut out = ScoreRows::default();
    read_csv(path, &[rows.scores_header()], |l, lineno, _| {
        let [s, e, score, st, flag] = if rows.flagged {
            fields::<5>(l, path, lineno)?
        } else {
            let [s, e, score, st] = fields::<4>(l, path, lineno)?;
            [s, e, score, st, "0"]
        };
        let sample: u64 = parse(s, "sample", path, lineno)?;
        let episode: u64 = parse(e, "episode", path, lineno)?;
        let i = out.scores.len();
        let (want_s, want_e) = ((i / episodes) as u64, (i % episodes) as u64);
        if (sample, episode) != (want_s, want_e) {
            return Err(RunReadError::Csv {
                path: path.to_path_buf(),
                line: lineno,
                message: format!(
                    "expected sample {want_s} episode {want_e} (rows ordered by sample, then \
                     episode, {episodes} episodes each), found sample {sample} episode {episode}"
                ),
            });
        }
        out.scores.push(parse::<f64>(score, "score", path, lineno)?);
        out.steps.push(parse::<u32>(st, "steps", path, lineno)?);
        if rows.flagged {
            out.cut.push(match flag {
                "0" => false,
                "1" => true,
                _ => {
                    return Err(RunReadError::Csv {
                        path: path.to_path_buf(),
                        line: lineno,
                        message: format!("non_finite {flag:?} is not 0 or 1"),
                    })
                }
            });
        }
        Ok(true)
    })?;
    if out.scores.len() % episodes != 0 {
        return Err(RunReadError::Mismatch {
            path: path.to_path_buf(),
            message: format!(
                "the last sample has {} of {episodes} episodes",
                out.scores.len() % episodes
            ),
        });
    }
    Ok(out)
}

/// One row of `samples.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleRow {
    /// Sample index.
    pub sample: u64,
    /// The sample's statistics.
    pub stats: SampleStats,
    /// Rank by mean.
    pub rank: usize,
    /// In a flagged cell's file (`non_finite = "end"`): the network's
    /// episodes a value that was not finite ended.
    pub non_finite: Option<u32>,
}

/// Reads a `samples.csv` (either header: a flagged cell's has the
/// `non_finite` column).
pub fn read_samples_csv(path: &Path) -> Result<Vec<SampleRow>, RunReadError> {
    let mut rows = Vec::new();
    let headers = [SAMPLES_HEADER, SAMPLES_HEADER_FLAGGED];
    read_csv(path, &headers, |l, lineno, h| {
        let (f, non_finite) = if h == 1 {
            let f = fields::<8>(l, path, lineno)?;
            let n = parse::<u32>(f[7], "non_finite", path, lineno)?;
            ([f[0], f[1], f[2], f[3], f[4], f[5], f[6]], Some(n))
        } else {
            (fields::<7>(l, path, lineno)?, None)
        };
        let num = |i: usize, what: &str| parse::<f64>(f[i], what, path, lineno);
        rows.push(SampleRow {
            sample: parse(f[0], "sample", path, lineno)?,
            stats: SampleStats {
                mean: num(1, "mean")?,
                variance: num(2, "variance")?,
                std: num(3, "std")?,
                min: num(4, "min")?,
                max: num(5, "max")?,
            },
            rank: parse(f[6], "rank", path, lineno)?,
            non_finite,
        });
        Ok(true)
    })?;
    Ok(rows)
}

/// Reads the episode scores of one sample from a `scores.csv` (either
/// header), streaming up to that sample's last episode (what `rwg replay`
/// compares against).
pub fn read_sample_scores(
    path: &Path,
    sample: u64,
    episodes: u32,
) -> Result<Vec<f64>, RunReadError> {
    let mut out = Vec::with_capacity(episodes as usize);
    let headers = [SCORES_HEADER, SCORES_HEADER_FLAGGED];
    read_csv(path, &headers, |l, lineno, h| {
        let [s, _, score] = if h == 1 {
            let [s, e, score, _, _] = fields::<5>(l, path, lineno)?;
            [s, e, score]
        } else {
            let [s, e, score, _] = fields::<4>(l, path, lineno)?;
            [s, e, score]
        };
        if parse::<u64>(s, "sample", path, lineno)? == sample {
            out.push(parse::<f64>(score, "score", path, lineno)?);
        }
        Ok(out.len() < episodes as usize)
    })?;
    Ok(out)
}

/// Whether two floats agree to ~1e-9 relative (the same value computed with a
/// different summation order), `NaN` matching `NaN`.
fn close(a: f64, b: f64, scale: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-9 * scale.max(1.0)
}

/// Checks a `samples.csv` against the statistics recomputed from the scores:
/// one row per sample in order; mean, min, max and variance agree (to 1e-9
/// relative, allowing another summation order); and the ranks order the
/// file's own means as a stable argsort does.
pub(super) fn check_samples_csv(path: &Path, data: &CellData) -> Result<(), RunReadError> {
    let rows = read_samples_csv(path)?;
    if rows.len() != data.samples() {
        return Err(RunReadError::Mismatch {
            path: path.to_path_buf(),
            message: format!(
                "{} rows, but scores.csv has {} samples",
                rows.len(),
                data.samples()
            ),
        });
    }
    for (i, (row, s)) in rows.iter().zip(&data.stats).enumerate() {
        let bad = |what: &str, got: f64, want: f64| RunReadError::Csv {
            path: path.to_path_buf(),
            line: i + 2,
            message: format!("{what} {got} disagrees with scores.csv ({want})"),
        };
        if row.sample != i as u64 {
            return Err(RunReadError::Csv {
                path: path.to_path_buf(),
                line: i + 2,
                message: format!("expected sample {i}, found {}", row.sample),
            });
        }
        let scale = s.min.abs().max(s.max.abs());
        let r = &row.stats;
        for (what, got, want, sc) in [
            ("mean", r.mean, s.mean, scale),
            ("min", r.min, s.min, scale),
            ("max", r.max, s.max, scale),
            ("variance", r.variance, s.variance, scale * scale),
        ] {
            if !close(got, want, sc) {
                return Err(bad(what, got, want));
            }
        }
    }
    check_non_finite_counts(path, &rows, data)?;
    let file_means: Vec<f64> = rows.iter().map(|r| r.stats.mean).collect();
    let want = stats::ranks(&file_means);
    if let Some(i) = (0..rows.len()).find(|&i| rows[i].rank != want[i]) {
        return Err(RunReadError::Csv {
            path: path.to_path_buf(),
            line: i + 2,
            message: format!(
                "rank {} but sample {i} is at position {} when sorted by mean (stable)",
                rows[i].rank, want[i]
            ),
        });
    }
    Ok(())
}

/// Checks the `non_finite` column of a `samples.csv` (`rows`) against the
/// counts of the flagged episodes of `data`: present exactly in a flagged
/// cell's file, each network's count that of its scores.
fn check_non_finite_counts(
    path: &Path,
    rows: &[SampleRow],
    data: &CellData,
) -> Result<(), RunReadError> {
    let want = data.non_finite.as_deref();
    for (i, row) in rows.iter().enumerate() {
        let bad = |message: String| RunReadError::Csv {
            path: path.to_path_buf(),
            line: i + 2,
            message,
        };
        match (row.non_finite, want) {
            (None, None) => return Ok(()),
            (Some(_), None) => {
                return Err(bad(
                    "a non_finite column, but the cell's episodes carry no flag (its \
                     scores.csv has none)"
                        .into(),
                ))
            }
            (None, Some(_)) => {
                return Err(bad(
                    "no non_finite column, but the cell's scores.csv flags its episodes".into(),
                ))
            }
            (Some(got), Some(w)) if got != w[i] => {
                return Err(bad(format!(
                    "non_finite {got} disagrees with scores.csv ({} of the sample's episodes \
                     are flagged)",
                    w[i]
                )))
            }
            _ => {}
        }
    }
    Ok(())
}
