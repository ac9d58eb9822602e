//! Reading a run directory for analysis, and writing its derived files
//! (`samples.csv`, `stats.json`, `stats.csv`).
//!
//! [`Run::open`] reads `run.json` (and `manifest.toml` if present);
//! [`Run::load_cell`] reads one cell's `scores.csv` (and checks its
//! `samples.csv` against the scores when present), one cell at a time so a
//! large run never has to fit in memory at once; [`Run::summarize`] gives
//! every cell's [`CellSummary`].
//!
//! Malformed files give a [`RunReadError`] naming the file and, for CSV, the
//! 1-based line.

use crate::rundir::blocks::RunDirError;
use crate::rundir::checksum;
use crate::rundir::export::{csv_reader, csv_writer};
use crate::rundir::meta::{load_json, CellMeta, JsonFileError, RunMeta, RUN_FORMAT};
use crate::rundir::rows;
use crate::rundir::{
    cell_dir, MANIFEST, RUN_JSON, SAMPLES_CSV, SAMPLES_HEADER, SCORES_CSV, SCORES_HEADER,
};
use crate::stats::{self, CellSummary, SampleStats};
use rwg_env::float::fmt_f64;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Why a run directory could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunReadError {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// `run.json` is not valid.
    #[error("{how}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
        /// What it is and how to get it back, naming the file
        /// ([`crate::rundir::study::damaged_run_json`]).
        how: String,
    },
    /// The run was written in a layout this rwg does not read.
    #[error("{path}: run format {found}, this rwg reads format {expected}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Format found.
        found: u32,
        /// Format supported ([`RUN_FORMAT`]).
        expected: u32,
    },
    /// A CSV line is malformed.
    #[error("{path}:{line}: {message}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The directory holds no `run.json`: it is not a run directory.
    #[error(
        "{} is not a run directory ({why}): a run directory is what `rwg run` writes, \
         run.json, manifest.toml and cells/<env>__<arch>__<bias|nobias>/{hint}",
        dir.display()
    )]
    NotARunDir {
        /// The directory given.
        dir: PathBuf,
        /// Why not: it does not exist, or it has no `run.json`.
        why: String,
        /// A hint: nearby run directories, if any (empty or `; ...`).
        hint: String,
    },
    /// A file does not match the checksum recorded in the run's index (or
    /// has none).
    #[error(transparent)]
    Integrity(#[from] RunDirError),
    /// A file does not match its checksum, and reading it shows where.
    #[error("{check}\n  first bad row: {row}")]
    Damaged {
        /// The checksum failure.
        check: RunDirError,
        /// What reading the file found.
        row: Box<RunReadError>,
    },
    /// The run is not finished (in progress, or stopped), and what was
    /// asked needs a finished one.
    #[error(
        "{} is a run {progress}; `rwg status {}` shows how far it got, and \
         `{}` finishes it",
        dir.display(), crate::shell::sh_path(dir), crate::rundir::study::resume_command(dir)
    )]
    Unfinished {
        /// The run directory.
        dir: PathBuf,
        /// How far it has got.
        progress: Unfinished,
    },
    /// The directory holds what a run writes first (its lock, its
    /// manifest) but no `run.json` yet: a run being started.
    #[error(
        "{} is a run being started (or one stopped before it was set up): it has {what} but \
         no run.json yet, which rwg writes once the run is set up; run this again in a moment \
         (`rwg status {}` shows how far it got)",
        dir.display(), crate::shell::sh_path(dir)
    )]
    Starting {
        /// The directory.
        dir: PathBuf,
        /// What it holds (`rwg.lock`, `manifest.toml`).
        what: String,
    },
    /// A file disagrees with `run.json` or with another file.
    #[error("{path}: {message}")]
    Mismatch {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RunReadError + '_ {
    move |source| RunReadError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Whether `dir` holds a `run.json`.
fn is_run_dir(dir: &Path) -> bool {
    dir.join(RUN_JSON).is_file()
}

/// The run directories directly inside `dir`, sorted.
fn run_dirs_in(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| is_run_dir(p))
        .collect();
    out.sort();
    out
}

/// The error for a directory without `run.json`: a run whose first cell has
/// not finished (written by an rwg that wrote `run.json` only then), or no
/// run at all, with a hint: the run directories inside it, or the
/// nearest-named run directory beside it.
fn not_a_run_dir(dir: &Path) -> RunReadError {
    let run_json = dir.join(RUN_JSON);
    if std::fs::symlink_metadata(&run_json).is_ok() {
        // There, but not a file rwg reads: a folder or a device in its place.
        return RunReadError::Mismatch {
            path: run_json,
            message: format!(
                "not a regular file (a folder or device where rwg writes run.json); remove it, \
                 then run {} to rebuild it from the cells' own files",
                crate::rundir::study::resume_command(dir)
            ),
        };
    }
    if dir.join(MANIFEST).is_file() && dir.join(crate::rundir::CELLS).is_dir() {
        let manifest = std::fs::read_to_string(dir.join(MANIFEST)).ok();
        return RunReadError::Unfinished {
            dir: dir.to_path_buf(),
            progress: Unfinished {
                cells_done: 0,
                cells: study_cells(dir, None, manifest.as_deref()),
            },
        };
    }
    let mut first = vec![];
    if let Some(holder) = crate::rundir::lock::live_writer(dir) {
        first.push(format!(
            "{} (held by {holder})",
            crate::rundir::lock::LOCK_FILE
        ));
    }
    if dir.join(MANIFEST).is_file() {
        first.push(MANIFEST.to_string());
    }
    if !first.is_empty() {
        return RunReadError::Starting {
            dir: dir.to_path_buf(),
            what: first.join(" and "),
        };
    }
    let why = if dir.is_dir() {
        "it has no run.json"
    } else if dir.exists() {
        "it is a file"
    } else {
        "it does not exist"
    };
    let inside = if dir.is_dir() {
        run_dirs_in(dir)
    } else {
        vec![]
    };
    let shards = if dir.is_dir() {
        run_dirs_in(&dir.join("shards"))
    } else {
        vec![]
    };
    let hint = if !shards.is_empty() {
        // The layout of `rwg slurm`: the study's shards in DIR/shards/K.
        let q: Vec<String> = shards.iter().map(|p| crate::shell::sh_path(p)).collect();
        format!(
            "; it holds the {} shard directories of a study in shards/: `rwg status {}` shows \
             them, `rwg verify {}` checks one, `rwg merge {} --out {}` combines them",
            shards.len(),
            crate::shell::sh_path(dir),
            q[0],
            q.join(" "),
            crate::shell::sh_path(dir)
        )
    } else if !inside.is_empty() {
        let list: Vec<String> = inside
            .iter()
            .take(5)
            .map(|p| p.display().to_string())
            .collect();
        format!("; run directories inside it: {}", list.join(", "))
    } else {
        let parent = match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let siblings = run_dirs_in(&parent);
        let names: Vec<String> = siblings
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match rwg_env::suggest::nearest(&name, names.iter().map(String::as_str)) {
            Some(n) => format!("; did you mean {}?", dir.with_file_name(n).display()),
            None => String::new(),
        }
    };
    RunReadError::NotARunDir {
        dir: dir.to_path_buf(),
        why: why.into(),
        hint,
    }
}

/// `Ok` when `dir` holds a `run.json` (a run or a shard's directory), else
/// the "not a run directory" error with its hint.
pub fn require_run_dir(dir: &Path) -> Result<(), RunReadError> {
    if is_run_dir(dir) {
        Ok(())
    } else {
        Err(not_a_run_dir(dir))
    }
}

/// An opened run directory: its metadata, cells not loaded yet.
#[derive(Debug, Clone)]
pub struct Run {
    /// The run directory.
    pub dir: PathBuf,
    /// Contents of `run.json`.
    pub meta: RunMeta,
    /// Contents of `manifest.toml`, if present.
    pub manifest: Option<String>,
    /// Whether the run has checksums (format 2 on): a run written before
    /// them (format 1) is read unverified.
    pub verified: bool,
}

/// Cells' episodes already in memory, by cell directory name: every
/// episode's score and length, row-major `samples × episodes`, as the cell's
/// `scores.csv` holds them ([`crate::runner::RunReport::episodes`]).
pub type KeptEpisodes = std::collections::BTreeMap<String, (Vec<f64>, Vec<u32>)>;

/// One cell's scores with the per-sample statistics derived from them.
#[derive(Debug, Clone)]
pub struct CellData {
    /// The cell's entry in `run.json`.
    pub meta: CellMeta,
    /// Episodes per sample `E`.
    pub episodes: usize,
    /// Episode scores, row-major `N × E` (sample, then episode).
    pub scores: Vec<f64>,
    /// Episode lengths in steps, same layout as `scores`.
    pub steps: Vec<u32>,
    /// Per-sample statistics ([`stats::per_sample`]).
    pub stats: Vec<SampleStats>,
    /// Per-sample rank by mean ([`stats::ranks`]).
    pub ranks: Vec<usize>,
}

impl CellData {
    /// Builds a cell from its scores and steps (row-major `N × episodes`),
    /// computing the per-sample statistics.
    ///
    /// # Panics
    /// If the lengths are not a positive multiple of `episodes` or differ.
    pub fn new(meta: CellMeta, episodes: usize, scores: Vec<f64>, steps: Vec<u32>) -> Self {
        assert_eq!(
            scores.len(),
            steps.len(),
            "scores and steps differ in length"
        );
        let stats = stats::per_sample(&scores, episodes);
        let ranks = stats::ranks(&stats.iter().map(|s| s.mean).collect::<Vec<_>>());
        CellData {
            meta,
            episodes,
            scores,
            steps,
            stats,
            ranks,
        }
    }

    /// Number of samples `N`.
    pub fn samples(&self) -> usize {
        self.stats.len()
    }

    /// The episode scores of sample `i`.
    pub fn sample_scores(&self, i: usize) -> &[f64] {
        &self.scores[i * self.episodes..(i + 1) * self.episodes]
    }

    /// The sample means `M`.
    pub fn means(&self) -> Vec<f64> {
        self.stats.iter().map(|s| s.mean).collect()
    }

    /// The sample variances `V`.
    pub fn variances(&self) -> Vec<f64> {
        self.stats.iter().map(|s| s.variance).collect()
    }

    /// The cell's summary ([`stats::summarize_cell`]).
    pub fn summary(&self) -> CellSummary {
        stats::summarize_cell(
            &self.meta,
            self.episodes,
            &self.scores,
            &self.steps,
            &self.stats,
        )
    }
}

/// The statistics of a whole run: contents of `stats.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunStats {
    /// The run's metadata (`run.json`).
    pub run: RunMeta,
    /// One summary per cell, in `run.json` order.
    pub cells: Vec<CellSummary>,
}

impl Run {
    /// Opens a run directory: reads and checks `run.json`, reads
    /// `manifest.toml` if present.
    pub fn open(dir: impl AsRef<Path>) -> Result<Run, RunReadError> {
        let dir = dir.as_ref().to_path_buf();
        let path = dir.join(RUN_JSON);
        let meta: RunMeta = load_json(&path).map_err(|e| match e {
            JsonFileError::Io(e) if e.kind() == std::io::ErrorKind::NotFound => not_a_run_dir(&dir),
            JsonFileError::Io(e) => io_err(&path)(e),
            JsonFileError::Json(source) => RunReadError::Json {
                path: path.clone(),
                source,
                how: crate::rundir::study::damaged_run_json(&dir),
            },
        })?;
        if !(1..=RUN_FORMAT).contains(&meta.format) {
            return Err(RunReadError::Format {
                path,
                found: meta.format,
                expected: RUN_FORMAT,
            });
        }
        if let Some(sh) = meta.shard {
            return Err(RunReadError::Mismatch {
                path,
                message: format!(
                    "this directory holds shard {}/{} of a study, not every network: \
                     combine the shards with `rwg merge` first",
                    sh.index, sh.count
                ),
            });
        }
        let mpath = dir.join(MANIFEST);
        let max = crate::limits::MAX_RESOLVED_MANIFEST_BYTES;
        let manifest = match crate::limits::read_own_text(&mpath, max) {
            Ok(m) => Some(m),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(io_err(&mpath)(e)),
        };
        check_cell_list(&dir, &meta, manifest.as_deref())?;
        Ok(Run {
            dir,
            verified: meta.format >= 2,
            meta,
            manifest,
        })
    }

    /// The directory of a cell.
    pub fn cell_dir(&self, cell: &CellMeta) -> PathBuf {
        cell_dir(&self.dir, &cell.id.dir)
    }

    /// Reads one cell's `scores.csv`, checks its shape against `run.json`,
    /// and checks `samples.csv` (when present) against the scores.
    pub fn load_cell(&self, cell: &CellMeta) -> Result<CellData, RunReadError> {
        let dir = self.cell_dir(cell);
        let episodes = cell.episodes as usize;
        let spath = dir.join(SCORES_CSV);
        if episodes == 0 || cell.samples == 0 {
            return Err(RunReadError::Mismatch {
                path: self.dir.join(RUN_JSON),
                message: format!("cell {} has no episodes to analyse", cell.id.dir),
            });
        }
        let (scores, steps) = self.read_scores_verified(cell, &dir)?;
        let expected = cell.samples as usize * episodes;
        if scores.len() != expected {
            return Err(RunReadError::Mismatch {
                path: spath,
                message: format!(
                    "{} episode rows, but run.json says {} samples × {} episodes = {expected}",
                    scores.len(),
                    cell.samples,
                    episodes
                ),
            });
        }
        // Rows an episode cannot have are refused whatever the checksums say.
        let limit = cell.max_episode_steps.max(1);
        let bad = scores
            .iter()
            .zip(&steps)
            .enumerate()
            .find_map(|(i, (&s, &st))| {
                crate::rundir::blocks::check_episode(s, u64::from(st), limit)
                    .err()
                    .map(|m| (i, m))
            });
        if let Some((i, message)) = bad {
            return Err(RunReadError::Csv {
                path: spath,
                line: i + 2,
                message,
            });
        }
        let data = CellData::new(cell.clone(), episodes, scores, steps);
        let path = dir.join(SAMPLES_CSV);
        if self.verified || path.exists() {
            self.check_samples_verified(&dir, &data)?;
        }
        Ok(data)
    }

    /// Loads every cell in turn and summarises it.
    pub fn summarize(&self) -> Result<RunStats, RunReadError> {
        let cells = self
            .meta
            .cells
            .iter()
            .map(|c| self.load_cell(c).map(|d| d.summary()))
            .collect::<Result<_, _>>()?;
        Ok(RunStats {
            run: self.meta.clone(),
            cells,
        })
    }
}

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

/// Reads a CSV file: checks the header, then calls `row` with each data
/// record and its 1-based line number; `row` returns `false` to stop early.
/// A plain file (what rwg writes) is split by [`rows`]; any other goes
/// through the `csv` crate (fields trimmed, empty lines skipped, a BOM
/// allowed), which gives the same records for a plain one.
fn read_csv(
    path: &Path,
    header: &str,
    mut row: impl FnMut(Record<'_>, usize) -> Result<bool, RunReadError>,
) -> Result<(), RunReadError> {
    let empty = || RunReadError::Csv {
        path: path.to_path_buf(),
        line: 1,
        message: format!("empty file, expected header {header:?}"),
    };
    let bad_header = |found: &str| RunReadError::Csv {
        path: path.to_path_buf(),
        line: 1,
        message: format!("header is {found:?}, expected {header:?}"),
    };
    // One open file for the check and the read: a file renamed over `path`
    // in between cannot be read by the wrong path.
    let mut file = crate::limits::open_regular(path).map_err(io_err(path))?;
    if rows::is_plain_reader(&mut file).map_err(io_err(path))? {
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
                if text != header {
                    return Err(bad_header(text));
                }
            } else if !row(Record::Plain(text), lineno)? {
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
    if found.trim_start_matches('\u{feff}') != header {
        return Err(bad_header(&found));
    }
    for r in records {
        let r = r.map_err(|e| csv_error(path, e))?;
        let lineno = r.position().map_or(0, |p| p.line() as usize);
        if !row(Record::Csv(&r), lineno)? {
            break;
        }
    }
    Ok(())
}

/// Reads a `scores.csv` (`sample,episode,score,steps`, rows ordered by
/// sample then episode, `episodes` rows per sample) into row-major score and
/// step vectors.
pub fn read_scores_csv(path: &Path, episodes: usize) -> Result<(Vec<f64>, Vec<u32>), RunReadError> {
    let mut scores = Vec::new();
    let mut steps = Vec::new();
    read_csv(path, SCORES_HEADER, |l, lineno| {
        let [s, e, score, st] = fields::<4>(l, path, lineno)?;
        let sample: u64 = parse(s, "sample", path, lineno)?;
        let episode: u64 = parse(e, "episode", path, lineno)?;
        let i = scores.len();
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
        scores.push(parse::<f64>(score, "score", path, lineno)?);
        steps.push(parse::<u32>(st, "steps", path, lineno)?);
        Ok(true)
    })?;
    if scores.len() % episodes != 0 {
        return Err(RunReadError::Mismatch {
            path: path.to_path_buf(),
            message: format!(
                "the last sample has {} of {episodes} episodes",
                scores.len() % episodes
            ),
        });
    }
    Ok((scores, steps))
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
}

/// Reads a `samples.csv`.
pub fn read_samples_csv(path: &Path) -> Result<Vec<SampleRow>, RunReadError> {
    let mut rows = Vec::new();
    read_csv(path, SAMPLES_HEADER, |l, lineno| {
        let f = fields::<7>(l, path, lineno)?;
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
        });
        Ok(true)
    })?;
    Ok(rows)
}

/// Reads the episode scores of one sample from a `scores.csv`, streaming up
/// to that sample's last episode (what `rwg replay` compares against).
pub fn read_sample_scores(
    path: &Path,
    sample: u64,
    episodes: u32,
) -> Result<Vec<f64>, RunReadError> {
    let mut out = Vec::with_capacity(episodes as usize);
    read_csv(path, SCORES_HEADER, |l, lineno| {
        let [s, _, score, _] = fields::<4>(l, path, lineno)?;
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
fn check_samples_csv(path: &Path, data: &CellData) -> Result<(), RunReadError> {
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

/// The text of a `samples.csv` for the given per-sample statistics and ranks
/// (the run writer's own format, [`crate::rundir::export::write_sample_rows`]).
pub fn samples_csv(stats: &[SampleStats], ranks: &[usize]) -> String {
    let mut out = Vec::with_capacity(64 * (stats.len() + 1));
    crate::rundir::export::write_sample_rows(&mut out, stats, ranks).expect("writing to memory");
    String::from_utf8(out).expect("ASCII")
}

/// Writes `samples.csv` for a row-major `N × episodes` score matrix: what the
/// run writer calls so the file matches the analysis bit for bit.
pub fn write_samples_csv(path: &Path, scores: &[f64], episodes: usize) -> std::io::Result<()> {
    let st = stats::per_sample(scores, episodes);
    let ranks = stats::ranks(&st.iter().map(|s| s.mean).collect::<Vec<_>>());
    crate::rundir::export::write_atomic(path, samples_csv(&st, &ranks).as_bytes())
}

/// The text of a `scores.csv` for row-major `N × episodes` scores and steps.
pub fn scores_csv(scores: &[f64], steps: &[u32], episodes: usize) -> String {
    let mut w = csv_writer(Vec::with_capacity(24 * (scores.len() + 1)));
    w.write_record(SCORES_HEADER.split(','))
        .expect("writing to memory");
    for (i, (s, st)) in scores.iter().zip(steps).enumerate() {
        w.write_record([
            (i / episodes).to_string(),
            (i % episodes).to_string(),
            fmt_f64(*s),
            st.to_string(),
        ])
        .expect("writing to memory");
    }
    String::from_utf8(w.into_inner().expect("writing to memory")).expect("ASCII")
}

/// Writes `run.json` into `dir`.
pub fn write_run_json(dir: &Path, meta: &RunMeta) -> std::io::Result<()> {
    crate::rundir::meta::write_run_meta(dir, meta).map_err(std::io::Error::other)
}

/// Writes one cell's `scores.csv` and `samples.csv` under
/// `run_dir/cells/<cell.dir>/`, from row-major `N × cell.episodes` scores
/// and steps.
pub fn write_cell_files(
    run_dir: &Path,
    cell: &CellMeta,
    scores: &[f64],
    steps: &[u32],
) -> std::io::Result<()> {
    use crate::rundir::export::write_atomic_hashed;
    let dir = cell_dir(run_dir, &cell.id.dir);
    std::fs::create_dir_all(&dir)?;
    let e = cell.episodes as usize;
    let st = stats::per_sample(scores, e);
    let ranks = stats::ranks(&st.iter().map(|s| s.mean).collect::<Vec<_>>());
    let sums = [
        (
            SCORES_CSV,
            write_atomic_hashed(
                &dir.join(SCORES_CSV),
                scores_csv(scores, steps, e).as_bytes(),
            )?,
        ),
        (
            SAMPLES_CSV,
            write_atomic_hashed(&dir.join(SAMPLES_CSV), samples_csv(&st, &ranks).as_bytes())?,
        ),
    ];
    write_atomic_hashed(
        &dir.join(checksum::SUMS),
        checksum::sums_text(&sums).as_bytes(),
    )
    .map(|_| ())
}

mod cell_list;
mod spread;
mod stats_files;
pub mod synthetic;
mod unfinished;
mod verified;

pub use cell_list::check_cell_list;
use unfinished::study_cells;
pub use unfinished::Unfinished;

pub use stats_files::{stats_csv, stats_csv_header, stats_csv_row, write_stats};

pub use spread::{spread_csv_fields, CellSpreadError, SummarizeError, SPREAD_CSV_COLUMNS};

#[cfg(test)]
mod tests;
