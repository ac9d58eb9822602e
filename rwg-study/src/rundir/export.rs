//! Writers of the run directory's CSV files, and small formatting helpers.
//! Every CSV file rwg writes goes through [`csv_writer`] (the `csv` crate),
//! every one it reads through [`csv_reader`].
//!
//! Floats are written in shortest round-trip form (parsing gives the same
//! `f64` back). Files are written to a temporary name and renamed into place
//! when complete, so a reader never sees a half-written file under the final
//! name.

use crate::rundir::checksum::{Digest, HashingWriter};
use crate::rundir::rows;
use crate::rundir::rows::CellRows;
use crate::rundir::{SAMPLES_HEADER, SAMPLES_HEADER_FLAGGED};
use crate::stats::SampleStats;
use rwg_core::sampler::BlockResult;
use rwg_env::float::fmt_f64;
use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// A file written under `<name>.tmp` beside its target and renamed to its
/// final name by [`AtomicFile::commit`]. Dropped uncommitted, or when the
/// commit fails (a full disk, say), the temporary file is removed and the
/// final name is untouched. (A process killed while writing leaves its
/// `.tmp`; the next writer of that file removes it.)
///
/// The temporary file is created exclusively (`O_CREAT | O_EXCL`, which never
/// follows a symbolic link): a leftover `.tmp` of a killed run is removed
/// first (removing a link removes the link, not its target), and if anything
/// appears at that path in between, creation fails instead of writing
/// through it. Commit syncs the file, renames it, and syncs the directory,
/// so a committed file survives a crash of the machine too.
pub struct AtomicFile {
    tmp: PathBuf,
    path: PathBuf,
    /// `None` once committed (or given up).
    out: Option<HashingWriter<BufWriter<File>>>,
}

/// The `.tmp` path beside `path`.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    PathBuf::from(tmp)
}

impl AtomicFile {
    /// Starts writing `path`.
    pub fn create(path: &Path) -> io::Result<Self> {
        let tmp = tmp_path(path);
        match std::fs::remove_file(&tmp) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
            _ => {}
        }
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| {
                io::Error::new(e.kind(), format!("cannot create {}: {e}", tmp.display()))
            })?;
        Ok(AtomicFile {
            tmp,
            path: path.to_path_buf(),
            out: Some(HashingWriter::new(BufWriter::with_capacity(1 << 16, file))),
        })
    }

    /// Flushes, syncs and renames the file into place, and syncs its
    /// directory.
    pub fn commit(self) -> io::Result<()> {
        self.commit_hashed().map(|_| ())
    }

    /// [`AtomicFile::commit`], returning the SHA-256 of the file's contents.
    pub fn commit_hashed(self) -> io::Result<Digest> {
        let path = self.path.clone();
        let digest = self.commit_hashed_keep_dir()?;
        sync_dir(&path)?;
        Ok(digest)
    }

    /// [`AtomicFile::commit_hashed`] without the sync of the directory: the
    /// file's contents are durable, its new name is not until the caller
    /// syncs the directory (once for several files).
    pub fn commit_hashed_keep_dir(self) -> io::Result<Digest> {
        self.finish(true)
    }

    /// Flushes and renames the file into place without syncing anything:
    /// the file survives the process being killed (its contents are in the
    /// kernel's page cache), not necessarily a crash of the machine, after
    /// which it may be empty or hold zeros. For files whose digest is
    /// recorded and checked before they are trusted (a cell's blocks: see
    /// [`crate::rundir::blocks::write_blocks`]).
    pub fn commit_hashed_unsynced(self) -> io::Result<Digest> {
        self.finish(false)
    }

    fn finish(mut self, sync: bool) -> io::Result<Digest> {
        let (mut out, digest) = self.out.take().expect("not committed yet").finish();
        let done = out
            .flush()
            .and_then(|()| match sync {
                true => out.get_ref().sync_all(),
                false => Ok(()),
            })
            .and_then(|()| std::fs::rename(&self.tmp, &self.path));
        drop(out);
        if done.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        done.map(|()| digest)
    }
}

impl Drop for AtomicFile {
    /// An uncommitted file's temporary file is removed.
    fn drop(&mut self) {
        if let Some(out) = self.out.take() {
            // The buffered rest is dropped unwritten.
            let _ = out.finish().0.into_parts();
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Whether `a` and `b` name the same existing file or folder (through any
/// links or other paths).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        #[cfg(unix)]
        (Ok(x), Ok(y)) => {
            use std::os::unix::fs::MetadataExt;
            (x.dev(), x.ino()) == (y.dev(), y.ino())
        }
        #[cfg(not(unix))]
        (Ok(_), Ok(_)) => std::fs::canonicalize(a).ok() == std::fs::canonicalize(b).ok(),
        _ => false,
    }
}

/// Creates folder `path`, whose parent must exist: a folder rwg makes in a
/// run directory it holds, never the run directory again (had it been moved
/// or deleted meanwhile, writes there fail rather than start a new one).
/// Nothing to do if it is a folder already.
pub fn create_dir_in(path: &Path) -> io::Result<()> {
    match std::fs::create_dir(path) {
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists && path.is_dir() => Ok(()),
        // (named, with what is in the way)
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => create_dir_all(path),
        r => r,
    }
}

/// Creates folder `path` and its parents, as [`std::fs::create_dir_all`];
/// when something on the way is not a folder (a file, or a symbolic link
/// to nothing), the error names it and says what it is, instead of "File
/// exists".
pub fn create_dir_all(path: &Path) -> io::Result<()> {
    let Err(e) = std::fs::create_dir_all(path) else {
        return Ok(());
    };
    let mut on_the_way: Vec<&Path> = path
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .collect();
    on_the_way.reverse();
    for a in on_the_way {
        let Ok(link) = std::fs::symlink_metadata(a) else {
            break; // nothing there: nor below
        };
        let what = match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => continue,
            Ok(_) => "a file, not a folder".to_string(),
            Err(_) if link.file_type().is_symlink() => {
                let to = std::fs::read_link(a).unwrap_or_default();
                format!(
                    "a symbolic link to {}, which does not exist (create that folder, or \
                     give another path)",
                    to.display()
                )
            }
            Err(_) => continue,
        };
        return Err(io::Error::new(
            e.kind(),
            format!("{} is {what}", a.display()),
        ));
    }
    Err(e)
}

/// Syncs the directory holding `path`, so a rename into it is durable. On
/// a file system that cannot sync folders (`fsync` fails with `EINVAL`,
/// `ENOTSUP` or `ENOSYS`: some FUSE mounts, CIFS) it does nothing: a rename
/// there may be lost in a crash of the machine, which the checksums catch
/// (what is missing or damaged is computed again), as for any file system
/// that does not write what it was told before a crash.
pub fn sync_dir(path: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        match File::open(dir)?.sync_all() {
            Err(e) if cannot_sync_folders(&e) => {}
            r => r?,
        }
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

/// Whether an `fsync` of a folder failed because the file system cannot
/// sync folders at all (rather than because the data could not be written).
#[cfg(unix)]
fn cannot_sync_folders(e: &io::Error) -> bool {
    matches!(
        e.raw_os_error(),
        Some(libc::EINVAL | libc::ENOTSUP | libc::ENOSYS)
    )
}

impl AtomicFile {
    fn writer(&mut self) -> &mut HashingWriter<BufWriter<File>> {
        self.out
            .as_mut()
            .expect("an AtomicFile is written before it is committed")
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer().write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer().write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer().flush()
    }
}

/// Writes a whole file atomically.
pub fn write_atomic(path: &Path, contents: &[u8]) -> io::Result<()> {
    write_atomic_hashed(path, contents).map(|_| ())
}

/// Writes a whole file atomically and returns its SHA-256.
pub fn write_atomic_hashed(path: &Path, contents: &[u8]) -> io::Result<Digest> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(contents)?;
    f.commit_hashed()
}

/// A CSV writer as rwg writes every CSV file: comma-separated, `\n` line
/// ends, a field quoted only when it must be (it holds a comma, a quote or a
/// line break). Headers are written as ordinary records.
pub fn csv_writer<W: Write>(out: W) -> csv::Writer<W> {
    csv::WriterBuilder::new()
        .has_headers(false)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(out)
}

/// A CSV reader as rwg reads its files: no header handling (the caller
/// checks the first record), records of any length (the caller checks the
/// count and names the file and line), fields trimmed of surrounding spaces
/// if `trim`. Empty lines are skipped.
pub fn csv_reader<R: io::Read>(input: R, trim: bool) -> csv::Reader<R> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(if trim {
            csv::Trim::All
        } else {
            csv::Trim::None
        })
        .buffer_capacity(1 << 16)
        .from_reader(input)
}

/// A CSV writer's error as an I/O error: writing CSV fails only on I/O.
pub fn csv_io_error(e: csv::Error) -> io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(e) => e,
        other => io::Error::other(format!("{other:?}")),
    }
}

/// Appends a block's rows to a `scores.csv` writer: `sample,episode,score,steps`
/// (and `non_finite` when `rows` are flagged; [`rows::push_score_rows`]).
pub fn write_score_rows<W: Write>(
    out: &mut W,
    block: &BlockResult,
    rows: impl Into<CellRows>,
) -> io::Result<()> {
    let mut buf = Vec::with_capacity(block.episodes.len() * 24);
    rows::push_score_rows(&mut buf, block, rows);
    out.write_all(&buf)
}

/// Writes `samples.csv` rows for samples `0..summaries.len()`; with
/// `non_finite` (a flagged cell's: each network's count of episodes a
/// value that was not finite ended), its column too.
pub fn write_sample_rows<W: Write>(
    out: &mut W,
    summaries: &[SampleStats],
    ranks: &[usize],
    non_finite: Option<&[u32]>,
) -> io::Result<()> {
    let mut w = csv_writer(out);
    let header = if non_finite.is_some() {
        SAMPLES_HEADER_FLAGGED
    } else {
        SAMPLES_HEADER
    };
    w.write_record(header.split(',')).map_err(csv_io_error)?;
    let mut row = Vec::with_capacity(8);
    for (i, (s, r)) in summaries.iter().zip(ranks).enumerate() {
        row.clear();
        row.extend([
            i.to_string(),
            fmt_f64(s.mean),
            fmt_f64(s.variance),
            fmt_f64(s.std),
            fmt_f64(s.min),
            fmt_f64(s.max),
            r.to_string(),
        ]);
        if let Some(n) = non_finite {
            row.push(n[i].to_string());
        }
        w.write_record(&row).map_err(csv_io_error)?;
    }
    w.flush()
}

/// A time as RFC 3339 UTC with second precision, e.g. `2026-11-22T05:40:00Z`.
pub fn rfc3339(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rwg_core::sampler::EpisodeResult;
    use std::time::Duration;

    #[test]
    fn a_folder_that_cannot_be_created_names_what_is_in_the_way() {
        let dir = std::env::temp_dir().join(format!("rwg-mkdir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("run")).unwrap();
        std::fs::write(dir.join("run/cells"), "").unwrap();
        let e = create_dir_all(&dir.join("run/cells/c1/blocks")).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} is a file, not a folder",
                dir.join("run/cells").display()
            )
        );
        std::os::unix::fs::symlink(dir.join("nowhere"), dir.join("link")).unwrap();
        let e = create_dir_all(&dir.join("link")).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "{} is a symbolic link to {}, which does not exist",
                dir.join("link").display(),
                dir.join("nowhere").display()
            )),
            "{e}"
        );
        create_dir_all(&dir.join("run/ok/a")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_uncommitted_or_failed_file_leaves_no_tmp() {
        let dir = std::env::temp_dir().join(format!("rwg-atomic-drop-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("f.csv");
        // dropped before its commit
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"half").unwrap();
        assert!(tmp_path(&p).exists());
        drop(f);
        assert!(!tmp_path(&p).exists() && !p.exists());
        // the rename fails: a non-empty directory holds the final name
        std::fs::create_dir_all(p.join("x")).unwrap();
        let err = write_atomic(&p, b"all").unwrap_err();
        assert!(!tmp_path(&p).exists(), "{err}");
        assert!(p.join("x").is_dir());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rfc3339_dates() {
        assert_eq!(rfc3339(UNIX_EPOCH), "1970-01-01T00:00:00Z");
        assert_eq!(
            rfc3339(UNIX_EPOCH + Duration::from_secs(1_795_326_000)),
            "2026-11-22T05:40:00Z"
        );
        assert_eq!(
            rfc3339(UNIX_EPOCH + Duration::from_secs(951_782_400)),
            "2000-02-29T00:00:00Z"
        );
    }

    #[test]
    fn score_rows() {
        let block = BlockResult {
            samples: 4..6,
            episodes: vec![
                EpisodeResult {
                    score: 1.5,
                    steps: 3,
                    non_finite: false,
                },
                EpisodeResult {
                    score: -0.1,
                    steps: 7,
                    non_finite: false,
                },
                EpisodeResult {
                    score: 200.0,
                    steps: 200,
                    non_finite: false,
                },
                EpisodeResult {
                    score: 1e-20,
                    steps: 1,
                    non_finite: false,
                },
            ],
        };
        let mut out = vec![];
        write_score_rows(&mut out, &block, 2).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "4,0,1.5,3\n4,1,-0.1,7\n5,0,200.0,200\n5,1,1e-20,1\n"
        );
    }

    #[test]
    fn atomic_file_appears_only_on_commit() {
        let dir = std::env::temp_dir().join(format!("rwg-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("x.csv");
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"a\n").unwrap();
        assert!(!p.exists());
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "a\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_planted_at_the_tmp_path_is_not_followed() {
        let dir = std::env::temp_dir().join(format!("rwg-atomic-link-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, "precious\n").unwrap();
        let p = dir.join("scores.csv");
        std::os::unix::fs::symlink(&victim, tmp_path(&p)).unwrap();
        write_atomic(&p, b"new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious\n");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
        assert!(!std::fs::symlink_metadata(&p)
            .unwrap()
            .file_type()
            .is_symlink());
        // A dangling link is not followed either (O_EXCL refuses it).
        let target = dir.join("created-through-link");
        std::os::unix::fs::symlink(&target, tmp_path(&p)).unwrap();
        write_atomic(&p, b"again\n").unwrap();
        assert!(!target.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
