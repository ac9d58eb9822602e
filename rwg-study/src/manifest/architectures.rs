//! The manifest's `[[architectures]]` entries: a unique name and hidden
//! layer sizes within rwg's limits for each, or `policy = "random"` (no
//! layers: uniformly random actions).

use super::checker::Checker;
use super::raw::RawArch;
use super::{ArchEntry, ManifestError};
use crate::limits;
use rwg_core::policy::PolicyKind;
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
    if earlier.iter().any(|x| x.name == name) {
        return Err(at.err(a.name.span(), format!("{key}.name: '{name}' is used twice")));
    }
    let policy = policy(at, key, a)?;
    let hidden = match (&a.hidden, policy) {
        (None, PolicyKind::Network) => {
            return Err(at.err(
                a.name.span(),
                format!(
                    "{key}: missing key `hidden` (the hidden layer sizes: [] for a linear \
                     network, [4, 4] for two layers of 4), or policy = \"random\" for \
                     uniformly random actions"
                ),
            ))
        }
        (None, PolicyKind::Random) => vec![],
        (Some(h), _) => {
            if h.get_ref().len() > limits::MAX_HIDDEN_LAYERS {
                return Err(at.err(
                    h.span(),
                    format!(
                        "{key}.hidden: at most {} layers (rwg's limit), got {}",
                        limits::MAX_HIDDEN_LAYERS,
                        h.get_ref().len()
                    ),
                ));
            }
            if policy == PolicyKind::Random && !h.get_ref().is_empty() {
                return Err(at.err(
                    h.span(),
                    format!(
                        "{key}.hidden: policy = \"random\" runs no network, so it has no \
                         layers; remove `hidden` (or write hidden = [])"
                    ),
                ));
            }
            hidden(at, key, h.get_ref())?
        }
    };
    Ok(ArchEntry {
        name,
        hidden,
        policy,
        name_span: a.name.span(),
    })
}

/// `policy`: `network` (the default) or `random`.
fn policy(at: &Checker, key: &str, a: &RawArch) -> Result<PolicyKind, ManifestError> {
    let Some(p) = &a.policy else {
        return Ok(PolicyKind::Network);
    };
    match p.get_ref().as_str() {
        "network" => Ok(PolicyKind::Network),
        "random" => Ok(PolicyKind::Random),
        other => Err(at.err(
            p.span(),
            format!(
                "{key}.policy: \"network\" (tanh networks, the default) or \"random\" \
                 (uniformly random actions, the random baseline), got \"{other}\""
            ),
        )),
    }
}

/// Whether `policy` is the default (not written in the resolved manifest).
pub(super) fn is_network(policy: &PolicyKind) -> bool {
    *policy == PolicyKind::Network
}

/// `policy` as the manifest writes it.
pub(super) fn serialize_policy<S: serde::Serializer>(
    policy: &PolicyKind,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.serialize_str(match policy {
        PolicyKind::Network => "network",
        PolicyKind::Random => "random",
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
