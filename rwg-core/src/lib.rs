//! # rwg-core
//!
//! Random Weight Guessing itself: the tanh [`policy`] networks (with the
//! numpy-exact [`tanh`]) and the [`sampler`] that draws their weights from
//! seeds and runs them on environments, in blocks of networks and lanes of
//! episodes side by side; [`batch`] and [`many`] are the same loop for
//! environments that step all lanes in one call (a remote Gymnasium worker,
//! a plugin's ABI 1.1 batched calls). The environment contract it runs against is
//! `rwg-env`; the study runner around it (manifest, run directory,
//! statistics) is `rwg-study`.

pub mod batch;
mod block;
pub mod many;
mod plan;
pub mod policy;
pub mod sampler;
pub mod tanh;
#[cfg(test)]
mod test_envs;
