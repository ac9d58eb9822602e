//! Fast reading and writing of the numeric CSV rows rwg writes itself.
//!
//! rwg's CSV files (`scores.csv`, `samples.csv`, block files) hold numbers
//! only, so the `csv` crate's per-record work (quoting, trimming, UTF-8
//! checks, a `String` per field) is most of the cost of reading or writing
//! them: in a 3000-network CartPole run it cost more CPU than the episodes.
//! A file is *plain* when every byte is printable ASCII other than a space
//! or a double quote, or `\n`, with no empty line: then splitting lines at
//! `\n` and fields at `,` gives exactly the records and line numbers the
//! `csv` reader gives (no quoting, nothing to trim, no line to skip), so
//! readers take this path for plain files and keep the `csv` crate for the
//! rest (a file edited by hand, a BOM, Windows line ends). Writers produce
//! the bytes the `csv` writer produced: numbers never need quoting.

use rwg_core::sampler::BlockResult;
use std::io::{self, Read, Write};
use std::path::Path;

/// Whether `bytes` are plain (see the module doc), given the byte before
/// them (`prev`; `\n` at the start of a file, where a first `\n` is an
/// empty first line, as `\n\n` across two chunks is an empty line).
fn plain_chunk(bytes: &[u8], prev: u8) -> bool {
    let mut prev = prev;
    for &c in bytes {
        let ok = match c {
            b'\n' => prev != b'\n',
            b'!'..=b'~' => c != b'"',
            _ => false,
        };
        if !ok {
            return false;
        }
        prev = c;
    }
    true
}

/// Whether `bytes` are a plain CSV text (see the module doc).
pub fn is_plain(bytes: &[u8]) -> bool {
    plain_chunk(bytes, b'\n')
}

/// Whether the file at `path` is plain, read in chunks (constant memory).
pub fn is_plain_file(path: &Path) -> io::Result<bool> {
    is_plain_reader(&mut crate::limits::open_regular(path)?)
}

/// Whether what `input` holds from where it is to its end is plain, read in
/// chunks (constant memory).
pub fn is_plain_reader(input: &mut impl Read) -> io::Result<bool> {
    let mut buf = vec![0u8; 1 << 16];
    let mut prev = b'\n';
    loop {
        let n = match input.read(&mut buf) {
            Ok(0) => return Ok(true),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if !plain_chunk(&buf[..n], prev) {
            return Ok(false);
        }
        prev = buf[n - 1];
    }
}

/// The lines of a text, without their `\n` (a last line without one is a
/// line too; the empty piece after a final `\n` is not).
pub fn lines(text: &str) -> Lines<'_> {
    Lines {
        rest: text.strip_suffix('\n').unwrap_or(text),
        done: text.is_empty(),
    }
}

/// The iterator of [`lines`]: a byte loop, cheaper per short line than
/// `str::split('\n')`'s searcher.
pub struct Lines<'a> {
    rest: &'a str,
    done: bool,
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a str;
    fn next(&mut self) -> Option<&'a str> {
        if self.done {
            return None;
        }
        let rest = self.rest;
        match rest.bytes().position(|c| c == b'\n') {
            // A newline's index is a character boundary.
            Some(i) => {
                self.rest = &rest[i + 1..];
                Some(&rest[..i])
            }
            None => {
                self.done = true;
                Some(rest)
            }
        }
    }
}

/// Splits a line into exactly `K` fields at `,`; otherwise `Err(n)` with the
/// number of fields it has.
pub fn split_fields<const K: usize>(line: &str) -> Result<[&str; K], usize> {
    let mut out = [""; K];
    let mut n = 0;
    let mut start = 0;
    // A plain byte loop: `str::split(',')`'s searcher, or an iterator chain,
    // costs several times more per short field. A comma's index is always a
    // character boundary.
    let bytes = line.as_bytes();
    for i in 0..bytes.len() {
        if bytes[i] == b',' {
            if n < K {
                out[n] = &line[start..i];
            }
            n += 1;
            start = i + 1;
        }
    }
    if n < K {
        out[n] = &line[start..];
    }
    n += 1;
    if n == K {
        Ok(out)
    } else {
        Err(n)
    }
}

/// The rows of a cell's score files (`scores.csv`, its blocks): episodes
/// per network, and whether each row ends with the `non_finite` flag (a
/// cell whose manifest entry has `non_finite = "end"`; the other cells'
/// files have no such column).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellRows {
    /// Episodes per network.
    pub episodes: u32,
    /// Rows end with `,0` or `,1`: whether a value that was not finite
    /// ended the episode.
    pub flagged: bool,
}

impl From<u32> for CellRows {
    /// Rows of `episodes` episodes per network, without the flag.
    fn from(episodes: u32) -> CellRows {
        CellRows {
            episodes,
            flagged: false,
        }
    }
}

impl CellRows {
    /// The header of the cell's `scores.csv`.
    pub fn scores_header(self) -> &'static str {
        if self.flagged {
            crate::rundir::SCORES_HEADER_FLAGGED
        } else {
            crate::rundir::SCORES_HEADER
        }
    }

    /// The header of the cell's `samples.csv`.
    pub fn samples_header(self) -> &'static str {
        if self.flagged {
            crate::rundir::SAMPLES_HEADER_FLAGGED
        } else {
            crate::rundir::SAMPLES_HEADER
        }
    }
}

/// Appends a block's rows (`sample,episode,score,steps`, then `,0` or `,1`
/// when `rows` are flagged; no header) to `out`: the bytes the `csv` writer
/// gave for them, scores in shortest round-trip form
/// ([`rwg_env::float::fmt_f64`]'s `{:?}`).
pub fn push_score_rows(out: &mut Vec<u8>, block: &BlockResult, rows: impl Into<CellRows>) {
    let rows = rows.into();
    let e = rows.episodes as usize;
    for (k, sample) in block.samples.clone().enumerate() {
        for (ep, r) in block.episodes[k * e..(k + 1) * e].iter().enumerate() {
            push_u64(out, sample);
            out.push(b',');
            push_u64(out, ep as u64);
            out.push(b',');
            push_f64(out, r.score);
            out.push(b',');
            push_u64(out, u64::from(r.steps));
            if rows.flagged {
                out.extend_from_slice(if r.non_finite { b",1" } else { b",0" });
            }
            out.push(b'\n');
        }
    }
}

/// Appends `x` as `{x:?}` formats it (shortest round trip). Integral
/// scores below 2^53 in magnitude (every episode of an env with integer
/// rewards: CartPole, Acrobot, MountainCar) are written by hand, `{x:?}`'s
/// `-12.0`; the rest through `{:?}`.
fn push_f64(out: &mut Vec<u8>, x: f64) {
    const EXACT: f64 = 9007199254740992.0; // 2^53 < 1e16, where {:?} turns to 1e16
    if x.fract() == 0.0 && x.abs() < EXACT {
        if x.is_sign_negative() {
            out.push(b'-');
        }
        push_u64(out, x.abs() as u64);
        out.extend_from_slice(b".0");
    } else {
        // Writing into a Vec cannot fail.
        let _ = write!(out, "{x:?}");
    }
}

/// Appends `v` in decimal, as `{v}` formats it.
fn push_u64(out: &mut Vec<u8>, mut v: u64) {
    let mut digits = [0u8; 20];
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[i..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scores_are_written_as_debug_writes_them() {
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            200.0,
            -500.0,
            0.5,
            -0.1,
            1e-7,
            1e15,
            9007199254740991.0,
            -9007199254740991.0,
            9007199254740992.0,
            -9007199254740992.0,
            1e16,
            1e300,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut s: u64 = 3;
        for _ in 0..200_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let bits = s >> 1;
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            values.push(f64::from_bits(bits));
            values.push(((u - 0.5) * 2f64.powi((s % 60) as i32)).round());
            values.push((u - 0.5) * 1000.0);
        }
        for x in values {
            let mut out = vec![];
            push_f64(&mut out, x);
            assert_eq!(String::from_utf8(out).unwrap(), format!("{x:?}"), "{x:e}");
        }
    }
    use crate::rundir::export::csv_reader;

    /// The records and line numbers of the `csv` crate's reader as rwg
    /// configures it for analysis (trimmed, flexible).
    fn csv_records(text: &[u8]) -> Vec<(usize, Vec<String>)> {
        csv_reader(text, true)
            .into_records()
            .map(|r| {
                let r = r.unwrap();
                let line = r.position().unwrap().line() as usize;
                (line, r.iter().map(String::from).collect())
            })
            .collect()
    }

    fn plain_records(text: &[u8]) -> Vec<(usize, Vec<String>)> {
        lines(std::str::from_utf8(text).unwrap())
            .enumerate()
            .map(|(i, l)| {
                let fields = match split_fields::<1>(l) {
                    Ok(f) => f.len(),
                    Err(n) => n,
                };
                assert_eq!(fields, l.split(',').count());
                (i + 1, l.split(',').map(String::from).collect())
            })
            .collect()
    }

    #[test]
    fn plain_texts_split_as_the_csv_reader_splits_them() {
        let texts: &[&[u8]] = &[
            b"sample,episode,score,steps\n0,0,1.5,3\n0,1,-0.1,7\n",
            b"a,b\n1,2",
            b"1,,3,\n,\n4\n",
            b"x\n",
            b"",
            b"1e-20,NaN,inf,-inf\n",
        ];
        for t in texts {
            assert!(is_plain(t), "{:?}", String::from_utf8_lossy(t));
            assert_eq!(plain_records(t), csv_records(t), "{t:?}");
        }
    }

    #[test]
    fn anything_the_csv_reader_treats_specially_is_not_plain() {
        for t in [
            &b"a, b\n"[..],
            b"a,\"b\"\n",
            b"a\r\nb\n",
            b"a\n\nb\n",
            b"\na\n",
            b"\xef\xbb\xbfa\n",
            b"a\tb\n",
            b"caf\xc3\xa9\n",
        ] {
            assert!(!is_plain(t), "{:?}", String::from_utf8_lossy(t));
        }
    }

    #[test]
    fn a_plain_file_is_judged_across_chunk_boundaries() {
        let dir = std::env::temp_dir().join(format!("rwg-rows-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("x.csv");
        let mut text = "1,2\n".repeat(1 << 14).into_bytes(); // exactly 64 KiB
        assert_eq!(text.len(), 1 << 16);
        std::fs::write(&p, &text).unwrap();
        assert!(is_plain_file(&p).unwrap());
        text.extend_from_slice(b"\n3,4\n"); // an empty line right after the first chunk
        std::fs::write(&p, &text).unwrap();
        assert!(!is_plain_file(&p).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn integers_are_written_as_display_writes_them() {
        for v in [
            0,
            1,
            9,
            10,
            99,
            100,
            12345,
            u64::from(u32::MAX),
            u64::MAX - 1,
            u64::MAX,
        ] {
            let mut out = vec![];
            push_u64(&mut out, v);
            assert_eq!(out, v.to_string().into_bytes());
        }
    }

    #[test]
    fn fields_are_split_exactly() {
        assert_eq!(split_fields::<3>("1,,3"), Ok(["1", "", "3"]));
        assert_eq!(split_fields::<3>("1,2"), Err(2));
        assert_eq!(split_fields::<2>("1,2,3,4"), Err(4));
        assert_eq!(split_fields::<1>(""), Ok([""]));
    }
}
