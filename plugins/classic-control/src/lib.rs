//! The reference plugin: every environment in [`rwg_envs::REGISTRY`],
//! exported through the C ABI v1 with no environment code of its own.
//!
//! Ids are namespaced, `classic_control/<built-in id>` (e.g.
//! `classic_control/CartPole-v0`), so the plugin never collides with the
//! built-ins. Instances are the built-in envs without their time limit: the
//! host applies `max_episode_steps` from the descriptor, so a plugin episode
//! reproduces the built-in one bit for bit.
//!
//! Each env is exported with its concrete type (from [`rwg_envs::visit`]),
//! so the exported `step` and `step_many` call the env's `step` directly,
//! as the built-in sampler does, instead of through a trait object. Envs
//! with a lockstep version ([`rwg_envs::lockstep`]) also export it as ABI
//! 1.2's vector env ([`VEC_WIDTH`] lanes stepped as arrays per chunk), the
//! code `rwg run` steps the built-ins with.
//!
//! Config string: `""` (defaults) or `action_dtype=float32` /
//! `action_dtype=float64`, the dtype of the continuous action array (see
//! [`rwg_env::ActionDtype`]; it matters for Pendulum-v1 and
//! MountainCarContinuous-v0 only).

use std::any::Any;
use std::marker::PhantomData;

use rwg_env::plugin::PluginBuilder;
use rwg_env::{ActionDtype, EnvSpec, Environment};
use rwg_envs::lockstep::{LockstepEnv, LockstepVisitor};
use rwg_envs::{visit, visit_lockstep, EnvOptions, EnvVisitor, Registration, REGISTRY};

/// The namespace of this plugin's ids.
pub const NAMESPACE: &str = "classic_control";

/// Lanes of each lockstep env behind a vector env (the built-in sampler's
/// `rwg_core::sampler::LANES`).
pub const VEC_WIDTH: usize = 16;

/// Parses the config string into build options (with no time limit).
fn options(config: &str) -> Result<EnvOptions, String> {
    let mut opts = EnvOptions {
        // The host applies the time limit; u32::MAX means none.
        max_episode_steps: Some(u32::MAX),
        ..EnvOptions::default()
    };
    for item in config.split([',', ' ']).filter(|s| !s.is_empty()) {
        match item.split_once('=') {
            Some(("action_dtype", v)) => opts.action_dtype = v.parse::<ActionDtype>()?,
            _ => {
                return Err(format!(
                    "unknown config item '{item}' (expected action_dtype=float64 or action_dtype=float32)"
                ))
            }
        }
    }
    Ok(opts)
}

/// Adds the built-in env it is handed to the builder, with its concrete type.
struct Export {
    builder: PluginBuilder,
    reg: &'static Registration,
}

impl EnvVisitor for Export {
    type Output = PluginBuilder;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> PluginBuilder {
        let id = self.reg.id;
        let mut spec: EnvSpec = env.spec().clone();
        spec.id = format!("{NAMESPACE}/{id}");
        let builder = self.builder.env(
            spec,
            self.reg.summary,
            move |config: &str| -> Result<E, String> {
                let opts = options(config)?;
                visit(id, &opts, Exact::<E>(PhantomData)).map_err(|e| e.to_string())?
            },
        );
        let opts = options("").expect("the default config parses");
        visit_lockstep::<VEC_WIDTH, _>(id, &opts, ExportVec { builder, id })
            .unwrap_or_else(|v| v.builder)
    }
}

/// Gives the env just added its lockstep version as the vector env.
struct ExportVec {
    builder: PluginBuilder,
    id: &'static str,
}

impl LockstepVisitor for ExportVec {
    type Output = PluginBuilder;
    fn visit<M: LockstepEnv + Clone + Send + Sync + 'static>(self, _env: M) -> PluginBuilder {
        let id = self.id;
        self.builder
            .vec_env(move |config: &str| -> Result<M, String> {
                let opts = options(config)?;
                visit_lockstep::<VEC_WIDTH, _>(id, &opts, Exact::<M>(PhantomData))
                    .map_err(|_| format!("{id} has no lockstep version (a bug in the plugin)"))?
            })
    }
}

impl<M: 'static> LockstepVisitor for Exact<M> {
    type Output = Result<M, String>;
    fn visit<F: LockstepEnv + Clone + Send + Sync + 'static>(self, env: F) -> Result<M, String> {
        let any: Box<dyn Any> = Box::new(env);
        any.downcast::<M>()
            .map(|e| *e)
            .map_err(|_| "the env's type changed with its options (a bug in the plugin)".into())
    }
}

/// Hands back the env [`visit`] builds if it has the type `E` (the type
/// of an id does not depend on the options).
struct Exact<E>(PhantomData<E>);

impl<E: 'static> EnvVisitor for Exact<E> {
    type Output = Result<E, String>;
    fn visit<F: Environment + Clone + Send + Sync + 'static>(self, env: F) -> Result<E, String> {
        let any: Box<dyn Any> = Box::new(env);
        any.downcast::<E>()
            .map(|e| *e)
            .map_err(|_| "the env's type changed with its options (a bug in the plugin)".into())
    }
}

/// Describes the plugin: one export per registered built-in environment.
pub fn plugin() -> PluginBuilder {
    let mut b = PluginBuilder::new(NAMESPACE, env!("CARGO_PKG_VERSION"));
    for reg in REGISTRY {
        b = visit(reg.id, &EnvOptions::default(), Export { builder: b, reg })
            .unwrap_or_else(|e| panic!("registered env {} does not build: {e}", reg.id));
    }
    b
}

rwg_env::export_plugin!(plugin());
