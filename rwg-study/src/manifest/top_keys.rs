//! The manifest's top-level keys: `seed`, `samples`, `episodes`, `threads`,
//! `out` and `bias`, each checked where it stands.

use super::checker::Checker;
use super::ManifestError;
use crate::limits;
use std::path::PathBuf;
use toml::Spanned;

/// `seed`: a non-negative integer, 0 if absent.
pub(super) fn seed(at: &Checker, seed: Option<&Spanned<i64>>) -> Result<u64, ManifestError> {
    match seed {
        None => Ok(0),
        Some(s) if *s.get_ref() >= 0 => Ok(*s.get_ref() as u64),
        Some(s) => Err(at.err(
            s.span(),
            format!("seed: must be a non-negative integer, got {}", s.get_ref()),
        )),
    }
}

/// `samples`: networks per cell, 1 to rwg's limit.
pub(super) fn samples(at: &Checker, samples: &Spanned<i64>) -> Result<u64, ManifestError> {
    at.count(samples, "samples", 1, limits::MAX_SAMPLES)
}

/// `episodes`: episodes per network, 1 to rwg's limit.
pub(super) fn episodes(at: &Checker, episodes: &Spanned<i64>) -> Result<u32, ManifestError> {
    Ok(at.count(episodes, "episodes", 1, limits::MAX_EPISODES.into())? as u32)
}

/// `threads`: 1 to rwg's limit, `None` (all cores) if absent.
pub(super) fn threads(
    at: &Checker,
    threads: Option<&Spanned<i64>>,
) -> Result<Option<usize>, ManifestError> {
    threads
        .map(|t| {
            at.count(t, "threads", 1, limits::MAX_THREADS as u64)
                .map(|t| t as usize)
        })
        .transpose()
}

/// `out`: the run directory, a path of at most rwg's limit in bytes.
pub(super) fn out(
    at: &Checker,
    out: Option<Spanned<String>>,
) -> Result<Option<PathBuf>, ManifestError> {
    if let Some(o) = &out {
        at.short(o, "out", limits::MAX_PATH_BYTES)?;
    }
    Ok(out.map(|o| PathBuf::from(o.into_inner())))
}

/// `bias`: each of `false` and `true` at most once, at least one; `[false]`
/// if absent.
pub(super) fn bias(
    at: &Checker,
    bias: Option<&Spanned<Vec<bool>>>,
) -> Result<Vec<bool>, ManifestError> {
    let Some(b) = bias else {
        return Ok(vec![false]);
    };
    if b.get_ref().is_empty() {
        return Err(at.err(
            b.span(),
            "bias: needs at least one setting (false, true or both)".into(),
        ));
    }
    let given = b.get_ref();
    let times = |setting: bool| given.iter().filter(|&&s| s == setting).count();
    if times(false) > 1 || times(true) > 1 {
        return Err(at.err(b.span(), "bias: each setting may appear once".into()));
    }
    Ok(given.clone())
}
