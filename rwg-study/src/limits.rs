//! The largest counts, sizes and names rwg accepts (in manifests and on the
//! command line), checked when a study is loaded, before anything is written.
//!
//! Each maximum is far beyond a real study (the paper: 10^4 networks x 20
//! episodes, 4-unit layers) and small enough that the memory and time it
//! implies can be borne: a value past one is an error that states the limit,
//! never an allocation failure, a panic or a hang. The README lists them.
//! Files are read through [`read_bounded`], which stops at the limit.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// Networks per cell (`samples`, `--samples`). A run keeps one 40-byte
/// summary per network of the running cell: 400 MB at the limit.
pub const MAX_SAMPLES: u64 = 10_000_000;
/// Episodes per network (`episodes`, `--episodes`). A block of 32 networks
/// holds 16 bytes per episode: 5 MB per block in flight at the limit.
pub const MAX_EPISODES: u32 = 10_000;
/// Worker threads (`threads`, `--threads`).
pub const MAX_THREADS: usize = 1024;
/// Time limit of an episode (`max_episode_steps`).
pub const MAX_EPISODE_STEPS: u32 = 10_000_000;
/// Units of one hidden layer.
pub const MAX_LAYER_UNITS: usize = 4096;
/// Hidden layers of one architecture.
pub const MAX_HIDDEN_LAYERS: usize = 64;
/// Weights of one network (all layers, for a given env's observation and
/// action sizes): 8 MB per network, of which a worker holds 48 at a time.
pub const MAX_WEIGHTS: usize = 1_000_000;
/// `[[architectures]]` entries of a manifest.
pub const MAX_ARCHITECTURES: usize = 256;
/// Networks in one compiled call of a JAX env (`networks_per_call`): the
/// weights of a call's networks are sent at once.
pub const MAX_NETWORKS_PER_CALL: u32 = 65_536;
/// `[[envs]]` entries of a manifest.
pub const MAX_ENVS: usize = 256;
/// Bytes of an architecture name (it is part of a directory name).
pub const MAX_ARCH_NAME_BYTES: usize = 64;
/// Bytes of an environment id (it is part of a directory name).
pub const MAX_ENV_ID_BYTES: usize = 128;
/// Bytes of a plugin env's `config` string.
pub const MAX_CONFIG_BYTES: usize = 65_536;
/// Bytes of a path (`plugin`, `out`).
pub const MAX_PATH_BYTES: usize = 4096;
/// Bytes of a manifest file.
pub const MAX_MANIFEST_BYTES: u64 = 1 << 20;
/// Bytes of a run directory's `manifest.toml` read as text (the resolved
/// manifest: a manifest of [`MAX_MANIFEST_BYTES`] with every default
/// written out).
pub const MAX_RESOLVED_MANIFEST_BYTES: u64 = 16 << 20;
/// Bytes of a JSON file rwg reads (`run.json`, `cell.json`, a Slurm
/// `plan.json`): `run.json` of the largest study (every env and
/// architecture, both bias settings) is far below.
pub const MAX_JSON_BYTES: u64 = 256 << 20;
/// Bytes of a block file or of a `SHA256SUMS` index (a block of 32
/// networks at [`MAX_EPISODES`] is about 16 MB; the index of a cell at
/// [`MAX_SAMPLES`] about 25 MB).
pub const MAX_BLOCK_BYTES: u64 = 64 << 20;
/// Bytes of a `rwg rollout --actions-file` (a line per step).
pub const MAX_ACTIONS_FILE_BYTES: u64 = 256 << 20;
/// Env steps per environment of `rwg bench envs --steps` (hours at the
/// slowest env's rate).
pub const MAX_BENCH_STEPS: u64 = 10_000_000_000;
/// Seconds of `rwg run --step-timeout` (a week).
pub const MAX_STEP_TIMEOUT_S: u64 = 604_800;
/// The master seed (`seed`, `--seed`): the largest TOML integer, as the run
/// directory's `manifest.toml` holds it.
pub const MAX_SEED: u64 = i64::MAX as u64;
/// Shards of a study (`--shard K/N`: N).
pub const MAX_SHARDS: u64 = 100_000;

/// The contents of the file at `path`, reading at most `max` bytes: a
/// longer file, or one that never ends (`/dev/zero`, a pipe), is an error
/// (kind `FileTooLarge`) stating the limit, read no further. Its size is not
/// trusted beforehand (a device or `/proc` file states none).
pub fn read_bounded(path: &Path, max: u64) -> io::Result<Vec<u8>> {
    read_to_limit(File::open(path)?, max)
}

/// [`read_bounded`] of a file rwg wrote itself (in a run directory, a
/// Slurm study's folder): only a regular file (or a link to one) is read,
/// as [`open_regular`] opens it; a device or FIFO there is an error.
pub fn read_own_file(path: &Path, max: u64) -> io::Result<Vec<u8>> {
    read_to_limit(open_regular(path)?, max)
}

/// [`read_own_file`] as UTF-8 text (an error of kind `InvalidData` if it
/// is not).
pub fn read_own_text(path: &Path, max: u64) -> io::Result<String> {
    utf8(read_own_file(path, max)?)
}

/// What `file` holds, up to `max` bytes (see [`read_bounded`]).
fn read_to_limit(file: File, max: u64) -> io::Result<Vec<u8>> {
    let too_large = || {
        io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!(
                "it has more than {max} bytes, the most rwg reads of such a file (rwg's limit)"
            ),
        )
    };
    let size = file.metadata().map_or(0, |m| m.len());
    // Refused before reading when its size says so (a file growing while
    // it is read is still cut at the limit below).
    if size > max {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(max.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_large());
    }
    Ok(bytes)
}

/// `bytes` as text, or an error of kind `InvalidData` naming the first byte
/// that is not UTF-8.
fn utf8(bytes: Vec<u8>) -> io::Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("byte {} is not UTF-8 text", e.utf8_error().valid_up_to()),
        )
    })
}

/// Opens the file at `path` for streaming, if it is a regular file (a
/// symbolic link to one included): a device or FIFO in a run directory,
/// which rwg never writes there, is an error (kind `InvalidInput`) instead
/// of a read without end or an open that waits for a writer.
pub fn open_regular(path: &Path) -> io::Result<File> {
    let kind = std::fs::metadata(path)?.file_type();
    if !kind.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file (a device, FIFO or directory where rwg writes a file)",
        ));
    }
    File::open(path)
}

/// [`read_bounded`] as UTF-8 text (an error of kind `InvalidData` if it is not).
pub fn read_bounded_text(path: &Path, max: u64) -> io::Result<String> {
    utf8(read_bounded(path, max)?)
}

/// `Ok(v)` if `min <= v <= max`, else a message naming `key` and the range:
/// `samples: at most 10000000 (rwg's limit), got 4294967295`.
pub fn in_range<T>(key: &str, v: T, min: T, max: T) -> Result<T, String>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    if v < min {
        Err(format!("{key}: must be at least {min}, got {v}"))
    } else if v > max {
        Err(format!("{key}: at most {max} (rwg's limit), got {v}"))
    } else {
        Ok(v)
    }
}

/// `Ok(())` if `s` has at most `max` bytes, else a message naming `key`.
pub fn short_enough(key: &str, s: &str, max: usize) -> Result<(), String> {
    if s.len() > max {
        Err(format!(
            "{key}: at most {max} bytes (rwg's limit), got {}",
            s.len()
        ))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_stop_at_the_limit() {
        let dir = std::env::temp_dir().join(format!("rwg-limits-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("f");
        std::fs::write(&p, b"12345").unwrap();
        assert_eq!(read_bounded(&p, 5).unwrap(), b"12345");
        let e = read_bounded(&p, 4).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert_eq!(
            e.to_string(),
            "it has more than 4 bytes, the most rwg reads of such a file (rwg's limit)"
        );
        // a file that states no size and never ends
        let e = read_bounded(Path::new("/dev/zero"), 1 << 16).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        std::fs::write(&p, b"ab\xFFc").unwrap();
        let e = read_bounded_text(&p, 10).unwrap_err();
        assert_eq!(e.to_string(), "byte 2 is not UTF-8 text");
        assert!(open_regular(&p).is_ok());
        assert_eq!(read_own_file(&p, 10).unwrap(), b"ab\xFFc");
        let fifo = dir.join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo on a path of our own.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        // refused before it is opened: an open would wait for a writer
        let e = read_own_text(&fifo, 10).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        for odd in [Path::new("/dev/zero"), dir.as_path()] {
            let e = open_regular(odd).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{odd:?}");
        }
        assert_eq!(
            read_bounded_text(&dir.join("f"), 4).unwrap_err().kind(),
            io::ErrorKind::InvalidData
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn messages_state_the_limit() {
        assert_eq!(
            in_range("samples", 4_294_967_295u64, 1, MAX_SAMPLES).unwrap_err(),
            "samples: at most 10000000 (rwg's limit), got 4294967295"
        );
        assert_eq!(
            in_range("episodes", 0i64, 1, 10).unwrap_err(),
            "episodes: must be at least 1, got 0"
        );
        assert_eq!(in_range("x", 5u32, 1, 5), Ok(5));
        assert_eq!(
            short_enough("name", &"a".repeat(65), MAX_ARCH_NAME_BYTES).unwrap_err(),
            "name: at most 64 bytes (rwg's limit), got 65"
        );
    }
}
