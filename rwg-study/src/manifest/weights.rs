//! The manifest's `[weights]` table: the distribution networks' weights are
//! drawn from, and its scale.

use super::checker::Checker;
use super::raw::{Num, RawWeights};
use super::ManifestError;
use rwg_core::sampler::WeightDist;
use toml::Spanned;

/// The weight distribution: normal with scale 1 if the table is absent.
pub(super) fn weights(at: &Checker, w: Option<&RawWeights>) -> Result<WeightDist, ManifestError> {
    let Some(w) = w else {
        return Ok(WeightDist::Normal { std: 1.0 });
    };
    let scale = scale(at, w.scale.as_ref())?;
    let dist = distribution(at, w.distribution.as_ref(), scale)?;
    if let Some(s) = &w.scale {
        check_no_overflow(at, s, &dist)?;
    }
    Ok(dist)
}

/// `scale`: a positive finite number, 1 if absent.
fn scale(at: &Checker, scale: Option<&Spanned<Num>>) -> Result<f64, ManifestError> {
    let Some(s) = scale else {
        return Ok(1.0);
    };
    let v = s.get_ref().get();
    if !(v.is_finite() && v > 0.0) {
        return Err(at.err(
            s.span(),
            format!("weights.scale: must be a positive number, got {v}"),
        ));
    }
    Ok(v)
}

/// `distribution`: `normal` (the default) or `uniform`, with `scale`.
fn distribution(
    at: &Checker,
    distribution: Option<&Spanned<String>>,
    scale: f64,
) -> Result<WeightDist, ManifestError> {
    match distribution.map(|d| (d.get_ref().as_str(), d.span())) {
        None | Some(("normal", _)) => Ok(WeightDist::Normal { std: scale }),
        Some(("uniform", _)) => Ok(WeightDist::Uniform { a: scale }),
        Some((other, span)) => Err(at.err(
            span,
            format!(
                "weights.distribution: unknown distribution '{other}' (expected \"normal\" or \"uniform\")"
            ),
        )),
    }
}

/// A scale whose draws could overflow a 64-bit float is refused at `scale`.
fn check_no_overflow(
    at: &Checker,
    scale: &Spanned<Num>,
    dist: &WeightDist,
) -> Result<(), ManifestError> {
    if dist.scale() <= dist.max_scale() {
        return Ok(());
    }
    Err(at.err(
        scale.span(),
        format!(
            "weights.scale: {:e} is beyond what a {} distribution's draws \
             can take without overflowing a 64-bit float to infinity; the scale \
             must be above 0 and at most {:e}",
            dist.scale(),
            dist.name(),
            dist.max_scale()
        ),
    ))
}
