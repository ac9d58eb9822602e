//! Checksums of the run directory's committed files.
//!
//! Every committed block and every finished cell file has its SHA-256
//! recorded in a `SHA256SUMS` file beside it, in the format of `sha256sum`
//! (`<64 hex digits>  <file name>`, so `sha256sum -c SHA256SUMS` checks them
//! too):
//!
//! - `cells/<cell>/blocks/SHA256SUMS`: one line appended (and synced) per
//!   committed block, after the block's rename. A block counts as committed
//!   only when its line is there and its bytes match; a block file without a
//!   line (a run killed between the rename and the append) is computed again.
//! - `cells/<cell>/SHA256SUMS`: `scores.csv`, `cell.json`, `samples.csv` and
//!   `env.json` of a finished cell, written last: a cell is complete only when this file
//!   exists, and its files count only when they match it.
//!
//! SHA-256 (the `sha2` crate) rather than a faster non-cryptographic hash:
//! the bytes hashed are the CSV text rwg writes, small next to the
//! environment steps that produce them, and a standard digest lets anyone
//! check a run with `sha256sum` alone.

use crate::rundir::error::{io_err, RunDirError};
use sha2::{Digest as _, Sha256};
use std::collections::BTreeMap;
use std::fs::OpenOptions;
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Name of the checksum files.
pub const SUMS: &str = "SHA256SUMS";

/// A SHA-256 digest.
pub type Digest = [u8; 32];

/// The digest as 64 lowercase hex digits.
pub fn hex(d: &Digest) -> String {
    d.iter().map(|b| format!("{b:02x}")).collect()
}

fn parse_hex(s: &str) -> Option<Digest> {
    if s.len() != 64 || !s.bytes().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let mut d = [0u8; 32];
    for (i, b) in d.iter_mut().enumerate() {
        *b = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(d)
}

/// A writer that hashes what passes through it.
pub struct HashingWriter<W> {
    inner: W,
    hasher: Sha256,
}

impl<W: Write> HashingWriter<W> {
    /// Wraps `inner`.
    pub fn new(inner: W) -> Self {
        HashingWriter {
            inner,
            hasher: Sha256::new(),
        }
    }

    /// The writer and the digest of everything written.
    pub fn finish(self) -> (W, Digest) {
        (self.inner, self.hasher.finalize().into())
    }
}

impl<W: Write> Write for HashingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// A reader that hashes what passes through it.
pub struct HashingReader<R> {
    inner: R,
    hasher: Sha256,
}

impl<R: Read> HashingReader<R> {
    /// Wraps `inner`.
    pub fn new(inner: R) -> Self {
        HashingReader {
            inner,
            hasher: Sha256::new(),
        }
    }

    /// Reads what is left (so the digest covers the whole input) and returns
    /// the digest.
    pub fn finish(mut self) -> io::Result<Digest> {
        io::copy(&mut self, &mut io::sink())?;
        Ok(self.hasher.finalize().into())
    }
}

impl<R: Read> Read for HashingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }
}

/// The SHA-256 of a file's contents.
pub fn hash_file(path: &Path) -> io::Result<Digest> {
    HashingReader::new(crate::limits::open_regular(path)?).finish()
}

/// The SHA-256 of bytes in memory.
pub fn digest_of(bytes: &[u8]) -> Digest {
    Sha256::digest(bytes).into()
}

/// The entries of a `SHA256SUMS` file, by file name. With `strict`, a line
/// that is not `<hex>  <name>` is an error naming the line; otherwise it is
/// skipped (an index appended to by a run that was killed mid-line: the
/// block it would have named counts as not committed). `Ok(None)` if the file
/// does not exist.
pub fn read_sums(
    path: &Path,
    strict: bool,
) -> Result<Option<BTreeMap<String, Digest>>, RunDirError> {
    let text = match crate::limits::read_own_file(path, crate::limits::MAX_BLOCK_BYTES) {
        Ok(t) => t,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io_err(path)(e)),
    };
    let mut out = BTreeMap::new();
    let complete = match text.iter().rposition(|&c| c == b'\n') {
        Some(p) if !strict => &text[..=p],
        None if !strict => &[][..],
        _ => &text[..],
    };
    for (i, line) in complete.split(|&c| c == b'\n').enumerate() {
        if line.is_empty() && (!strict || i > 0) {
            continue;
        }
        let parsed = std::str::from_utf8(line)
            .ok()
            .and_then(|l| l.split_once("  "))
            .and_then(|(h, name)| Some((parse_hex(h)?, name)))
            .filter(|(_, name)| {
                !name.is_empty() && !name.contains(['/', '\\']) && !name.contains(char::is_control)
            });
        match parsed {
            Some((d, name)) => {
                out.insert(name.to_string(), d);
            }
            None if strict => {
                let message = if line.ends_with(b"\r") {
                    "ends in a carriage return: the file was rewritten with CRLF (Windows) line \
                     endings; rwg writes LF, so `sed -i 's/\\r$//' SHA256SUMS` restores it"
                } else {
                    "not a '<sha256>  <file>' line"
                };
                return Err(RunDirError::Corrupt {
                    path: path.to_path_buf(),
                    line: i + 1,
                    message: message.into(),
                });
            }
            None => {}
        }
    }
    Ok(Some(out))
}

/// Appends `<hex>  <name>` to the index `path` (created if missing) and
/// syncs it. A line left unfinished by a killed run is closed first, so the
/// new line stands on its own.
pub fn append_sum(path: &Path, name: &str, digest: &Digest) -> Result<(), RunDirError> {
    append_sums(path, &[(name, *digest)])
}

/// [`append_sum`] for several entries: one write of all their lines, one sync.
pub fn append_sums(path: &Path, entries: &[(&str, Digest)]) -> Result<(), RunDirError> {
    append_lines(path, entries, true)
}

/// [`append_sums`] without the sync: the lines survive the process being
/// killed, not necessarily a crash of the machine (after which the file may
/// end early or hold zeros, which [`read_sums`] skips unless `strict`).
pub fn append_sums_unsynced(path: &Path, entries: &[(&str, Digest)]) -> Result<(), RunDirError> {
    append_lines(path, entries, false)
}

fn append_lines(path: &Path, entries: &[(&str, Digest)], sync: bool) -> Result<(), RunDirError> {
    // The run's block committers append from several threads: one at a time,
    // so that the repair of a crash's partial last line below (read the last
    // byte, then write) cannot interleave with another append.
    static APPEND: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = APPEND.lock().unwrap_or_else(|e| e.into_inner());
    let mut opts = OpenOptions::new();
    opts.read(true).append(true).create(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NOFOLLOW);
    }
    let mut f = opts.open(path).map_err(io_err(path))?;
    let len = f.seek(SeekFrom::End(0)).map_err(io_err(path))?;
    let mut text = String::new();
    if len > 0 {
        f.seek(SeekFrom::Start(len - 1)).map_err(io_err(path))?;
        let mut last = [0u8];
        f.read_exact(&mut last).map_err(io_err(path))?;
        if last[0] != b'\n' {
            text.push('\n');
        }
    }
    text.push_str(&sums_text(entries));
    f.write_all(text.as_bytes()).map_err(io_err(path))?;
    if sync {
        f.sync_all().map_err(io_err(path))?;
    }
    Ok(())
}

/// The text of a `SHA256SUMS` file listing `entries` in the given order.
pub fn sums_text(entries: &[(&str, Digest)]) -> String {
    entries
        .iter()
        .map(|(name, d)| format!("{}  {name}\n", hex(d)))
        .collect()
}

/// Checks that `dir/name` has the digest `want`; the error names the file.
pub fn verify_file(dir: &Path, name: &str, want: &Digest) -> Result<(), RunDirError> {
    let path = dir.join(name);
    let got = hash_file(&path).map_err(io_err(&path))?;
    check(&path, want, &got)
}

/// A [`RunDirError::Checksum`] if `got` is not `want`.
pub fn check(path: &Path, want: &Digest, got: &Digest) -> Result<(), RunDirError> {
    if want == got {
        return Ok(());
    }
    Err(RunDirError::Checksum {
        path: path.to_path_buf(),
        recorded: hex(want),
        found: hex(got),
    })
}

/// The recorded digest of `name` in the cell directory `dir`'s `SHA256SUMS`:
/// an error naming the file if the cell has no `SHA256SUMS` (not finished)
/// or it does not list `name`.
pub fn recorded(dir: &Path, name: &str) -> Result<Digest, RunDirError> {
    let sums_path = dir.join(SUMS);
    let sums = read_sums(&sums_path, true)?.ok_or_else(|| RunDirError::Unverified {
        path: dir.join(name),
        message: format!(
            "{} is missing, so the cell is not finished (or its index was deleted); \
             run the study again to finish it",
            sums_path.display()
        ),
    })?;
    sums.get(name)
        .copied()
        .ok_or_else(|| RunDirError::Unverified {
            path: dir.join(name),
            message: format!("not listed in {}", sums_path.display()),
        })
}

/// Checks every file a finished cell's `SHA256SUMS` lists; returns the
/// files checked.
pub fn verify_cell(dir: &Path) -> Result<Vec<PathBuf>, RunDirError> {
    let sums_path = dir.join(SUMS);
    let sums = read_sums(&sums_path, true)?.ok_or_else(|| RunDirError::Unverified {
        path: sums_path.clone(),
        message: "missing: the cell is not finished".into(),
    })?;
    let mut checked = vec![];
    for (name, d) in &sums {
        verify_file(dir, name, d)?;
        checked.push(dir.join(name));
    }
    Ok(checked)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rwg-sums-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn sha256_of_known_input() {
        let d: Digest = Sha256::digest(b"abc").into();
        assert_eq!(
            hex(&d),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(parse_hex(&hex(&d)), Some(d));
    }

    #[test]
    fn index_survives_a_half_written_line() {
        let dir = temp("index");
        let p = dir.join(SUMS);
        let d0: Digest = Sha256::digest(b"0").into();
        let d1: Digest = Sha256::digest(b"1").into();
        append_sum(&p, "b0000000.csv", &d0).unwrap();
        // a run killed while appending
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        f.write_all(b"5feceb66ffc86f38d952786c6d696c79c2dbc2")
            .unwrap();
        let sums = read_sums(&p, false).unwrap().unwrap();
        assert_eq!(sums.len(), 1);
        append_sum(&p, "b0000001.csv", &d1).unwrap();
        let sums = read_sums(&p, false).unwrap().unwrap();
        assert_eq!(sums.get("b0000000.csv"), Some(&d0));
        assert_eq!(sums.get("b0000001.csv"), Some(&d1));
        let e = read_sums(&p, true).unwrap_err().to_string();
        assert!(e.contains("SHA256SUMS:2: not a"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn cell_files_are_checked_against_their_sums() {
        let dir = temp("cell");
        std::fs::write(dir.join("scores.csv"), "a\n").unwrap();
        let d = hash_file(&dir.join("scores.csv")).unwrap();
        std::fs::write(dir.join(SUMS), sums_text(&[("scores.csv", d)])).unwrap();
        assert_eq!(verify_cell(&dir).unwrap().len(), 1);
        std::fs::write(dir.join("scores.csv"), "b\n").unwrap();
        let e = verify_cell(&dir).unwrap_err().to_string();
        assert!(e.contains("scores.csv: checksum mismatch"), "{e}");
        let e = recorded(&dir, "samples.csv").unwrap_err().to_string();
        assert!(e.contains("not listed"), "{e}");
        std::fs::remove_file(dir.join(SUMS)).unwrap();
        let e = recorded(&dir, "scores.csv").unwrap_err().to_string();
        assert!(e.contains("not finished"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
