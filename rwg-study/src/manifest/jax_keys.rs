//! The keys of JAX envs (`gymnax:`, `brax:`, `playground:`, ...,
//! `jax:module:callable`: [`rwg_jax::FAMILIES`]) in an `[[envs]]` entry:
//! `precision`, `matmul_precision`, `device`, `networks_per_call`,
//! `action_mask`, checked where they stand, and the keys a JAX env does not
//! take (`plugin`, `config`, `isolate`, `action_dtype`) refused there; the
//! same four keys on any other env are refused too.

use super::raw::RawEnv;
use crate::limits;
use rwg_jax::{MatmulPrecision, Precision, NETWORKS_MULTIPLE};
use std::ops::Range;
use toml::Spanned;

/// The JAX keys of one entry, checked.
pub(super) struct JaxKeys {
    /// `Some` for a JAX env (the manifest's, else float32), `None` for others.
    pub precision: Option<Precision>,
    /// `Some` for a JAX env (the manifest's, else highest), `None` for others.
    pub matmul_precision: Option<MatmulPrecision>,
    /// The device asked for, if any.
    pub device: Option<String>,
    /// Networks per compiled call, if given.
    pub networks_per_call: Option<u32>,
    /// `Some` for a JAX env (the manifest's, else true), `None` for others.
    pub action_mask: Option<bool>,
}

/// What a located error is made of: where, and the message.
type Located = (Range<usize>, String);

/// Checks the JAX keys of entry `key` (`envs[i]`) with id `id`.
pub(super) fn check(key: &str, id: &str, e: &RawEnv) -> Result<JaxKeys, Located> {
    let given: [(&str, Option<Range<usize>>); 5] = [
        ("precision", e.precision.as_ref().map(Spanned::span)),
        (
            "matmul_precision",
            e.matmul_precision.as_ref().map(Spanned::span),
        ),
        ("device", e.device.as_ref().map(Spanned::span)),
        (
            "networks_per_call",
            e.networks_per_call.as_ref().map(Spanned::span),
        ),
        ("action_mask", e.action_mask.as_ref().map(Spanned::span)),
    ];
    let Some((kind, rest)) = rwg_jax::jax_id(id) else {
        if let Some((name, Some(at))) = given.into_iter().find(|(_, s)| s.is_some()) {
            return Err((
                at,
                format!(
                    "{key}.{name}: applies to JAX environments only (ids {}); '{id}' is not one",
                    rwg_jax::id_forms()
                ),
            ));
        }
        return Ok(JaxKeys {
            precision: None,
            matmul_precision: None,
            device: None,
            networks_per_call: None,
            action_mask: None,
        });
    };
    refuse_other_keys(key, id, e)?;
    if matches!(kind, rwg_jax::JaxKind::Custom) && !rest.contains(':') {
        return Err((
            e.id.span(),
            format!(
                "{key}.id: '{id}' names no callable; a jax: id is jax:module:callable \
                 (e.g. jax:my_pkg.envs:make_env, where make_env(**kwargs) returns (env, params))"
            ),
        ));
    }
    let precision = match &e.precision {
        None => Precision::F32,
        Some(p) => Precision::from_name(p.get_ref()).ok_or_else(|| {
            (
                p.span(),
                format!(
                    "{key}.precision: expected \"float32\" or \"float64\" (the precision JAX \
                     computes the env and the networks in), got {:?}",
                    p.get_ref()
                ),
            )
        })?,
    };
    let matmul_precision = match &e.matmul_precision {
        None => MatmulPrecision::default(),
        Some(p) => MatmulPrecision::from_name(p.get_ref()).ok_or_else(|| {
            (
                p.span(),
                format!(
                    "{key}.matmul_precision: expected \"highest\" (full float32 products, the \
                     default), \"high\" or \"default\" (faster, lower-precision products on \
                     some GPUs and TPUs), got {:?}",
                    p.get_ref()
                ),
            )
        })?,
    };
    let device = match &e.device {
        None => None,
        Some(d) => Some(device(key, d)?),
    };
    let networks_per_call = match &e.networks_per_call {
        None => None,
        Some(n) => Some(networks_per_call(key, n)?),
    };
    Ok(JaxKeys {
        precision: Some(precision),
        matmul_precision: Some(matmul_precision),
        device,
        networks_per_call,
        action_mask: Some(e.action_mask.as_ref().is_none_or(|m| *m.get_ref())),
    })
}

/// `plugin`, `config`, `isolate` and `action_dtype` on a JAX env.
fn refuse_other_keys(key: &str, id: &str, e: &RawEnv) -> Result<(), Located> {
    let other: [(&str, Option<Range<usize>>); 4] = [
        ("plugin", e.plugin.as_ref().map(Spanned::span)),
        ("config", e.config.as_ref().map(Spanned::span)),
        ("isolate", e.isolate.as_ref().map(Spanned::span)),
        ("action_dtype", e.action_dtype.as_ref().map(Spanned::span)),
    ];
    match other.into_iter().find(|(_, s)| s.is_some()) {
        Some((name, Some(at))) => Err((
            at,
            format!(
                "{key}.{name}: '{id}' is a JAX environment, which takes no `{name}`: its \
                 arguments go in `kwargs = {{ ... }}`, its arithmetic in `precision` \
                 (\"float32\" or \"float64\"), and it always runs in JAX worker processes"
            ),
        )),
        _ => Ok(()),
    }
}

/// `device = "kind[:index]"`: a JAX platform name and an optional index.
fn device(key: &str, d: &Spanned<String>) -> Result<String, Located> {
    let v = d.get_ref();
    let (kind, index) = match v.split_once(':') {
        Some((k, i)) => (k, Some(i)),
        None => (v.as_str(), None),
    };
    let kind_ok = !kind.is_empty()
        && kind.len() <= 32
        && kind.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    let index_ok = index
        .is_none_or(|i| !i.is_empty() && i.len() <= 6 && i.bytes().all(|b| b.is_ascii_digit()));
    if kind_ok && index_ok {
        Ok(v.clone())
    } else {
        Err((
            d.span(),
            format!(
                "{key}.device: expected a JAX device kind with an optional index, such as \
                 \"cpu\", \"gpu\", \"gpu:1\" or \"tpu\", got {v:?}"
            ),
        ))
    }
}

/// `networks_per_call`: a multiple of 32 (rwg's blocks) up to rwg's limit.
fn networks_per_call(key: &str, n: &Spanned<i64>) -> Result<u32, Located> {
    let v = *n.get_ref();
    let max = limits::MAX_NETWORKS_PER_CALL;
    let block = i64::from(NETWORKS_MULTIPLE);
    if v < block || v > i64::from(max) || v % block != 0 {
        return Err((
            n.span(),
            format!(
                "{key}.networks_per_call: must be a multiple of {block} (rwg's blocks of \
                 networks) from {block} to {max} (rwg's limit), got {v}"
            ),
        ));
    }
    Ok(v as u32)
}

/// Whether the manifest writes an env's `action_mask`: only when it is
/// `false` (`true`, the default of a JAX env, and `None`, any other env's,
/// are left out, so that a manifest without the key reads back the same).
pub(super) fn mask_is_default(m: &Option<bool>) -> bool {
    *m != Some(false)
}

/// A JAX key's value with a name in the manifest.
pub(super) trait Named: Copy {
    /// The manifest's name of the value.
    fn name(self) -> &'static str;
}

impl Named for Precision {
    fn name(self) -> &'static str {
        Precision::name(self)
    }
}

impl Named for MatmulPrecision {
    fn name(self) -> &'static str {
        MatmulPrecision::name(self)
    }
}

/// Writes an env's precision (`"float32"`) or matmul precision
/// (`"highest"`) as the manifest spells it.
pub(super) fn serialize_name<T: Named, S: serde::Serializer>(
    p: &Option<T>,
    s: S,
) -> Result<S::Ok, S::Error> {
    match p {
        Some(p) => s.serialize_str(p.name()),
        None => s.serialize_none(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn networks_per_call_counts_in_rwgs_blocks() {
        assert_eq!(
            u64::from(super::NETWORKS_MULTIPLE),
            crate::rundir::blocks::BLOCK_SAMPLES
        );
    }
}
