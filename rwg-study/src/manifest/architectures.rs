//! The manifest's `[[architectures]]` entries: a unique name and hidden
//! layer sizes within rwg's limits for each.

use super::checker::Checker;
use super::raw::RawArch;
use super::{ArchEntry, ManifestError};
use crate::limits;
use toml::Spanned;

/// The architectures: at least one, at most rwg's limit, names unique.
pub(super) fn architectures(
    at: &Checker,
    raw: &Spanned<Vec<RawArch>>,
) -> Result<Vec<ArchEntry>, ManifestError> {
    at.entry_count(
        raw,
        "architectures",
        "one architecture",
        limits::MAX_ARCHITECTURES,
        |e| e.name.span(),
    )?;
    let mut architectures = Vec::new();
    for (i, a) in raw.get_ref().iter().enumerate() {
        let entry = architecture(at, &format!("architectures[{i}]"), a, &architectures)?;
        architectures.push(entry);
    }
    Ok(architectures)
}

/// Entry `key` (`architectures[i]`), whose name none of `earlier` has.
fn architecture(
    at: &Checker,
    key: &str,
    a: &RawArch,
    earlier: &[ArchEntry],
) -> Result<ArchEntry, ManifestError> {
    let name = a.name.get_ref().trim().to_string();
    if name.is_empty() {
        return Err(at.err(a.name.span(), format!("{key}.name: must not be empty")));
    }
    at.short(&a.name, &format!("{key}.name"), limits::MAX_ARCH_NAME_BYTES)?;
    if a.hidden.get_ref().len() > limits::MAX_HIDDEN_LAYERS {
        return Err(at.err(
            a.hidden.span(),
            format!(
                "{key}.hidden: at most {} layers (rwg's limit), got {}",
                limits::MAX_HIDDEN_LAYERS,
                a.hidden.get_ref().len()
            ),
        ));
    }
    if earlier.iter().any(|x| x.name == name) {
        return Err(at.err(a.name.span(), format!("{key}.name: '{name}' is used twice")));
    }
    Ok(ArchEntry {
        name,
        hidden: hidden(at, key, a.hidden.get_ref())?,
        name_span: a.name.span(),
    })
}

/// `hidden`: each layer 1 to rwg's limit of units.
fn hidden(at: &Checker, key: &str, layers: &[Spanned<i64>]) -> Result<Vec<usize>, ManifestError> {
    let mut hidden = Vec::new();
    for (j, h) in layers.iter().enumerate() {
        if !(1..=limits::MAX_LAYER_UNITS as i64).contains(h.get_ref()) {
            return Err(at.err(
                h.span(),
                format!(
                    "{key}.hidden[{j}]: a layer needs 1 to {} units (rwg's limit), got {}",
                    limits::MAX_LAYER_UNITS,
                    h.get_ref()
                ),
            ));
        }
        hidden.push(*h.get_ref() as usize);
    }
    Ok(hidden)
}
