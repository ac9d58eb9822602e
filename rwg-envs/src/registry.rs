//! The registry of built-in environments, by Gymnasium id.
//!
//! [`visit`] hands the caller a concrete, `TimeLimit`-wrapped environment
//! type, so code written against a generic `E: Environment` is monomorphised
//! for every built-in env (no dynamic dispatch in the step loop). [`make`]
//! returns a boxed env for code that does not need that speed.

use rwg_env::{ActionDtype, Environment, TimeLimit};
use thiserror::Error;

use crate::acrobot::Acrobot;
use crate::cartpole::CartPole;
use crate::mountain_car::MountainCar;
use crate::mountain_car_continuous::MountainCarContinuous;
use crate::pendulum::Pendulum;

/// Settings that change how a built-in environment is built.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnvOptions {
    /// dtype of the continuous action array (Pendulum-v1, MountainCarContinuous-v0;
    /// Pendulum-v0 only rounds an `F32` action to f32, its arithmetic is float64).
    pub action_dtype: ActionDtype,
    /// Overrides the registered time limit.
    pub max_episode_steps: Option<u32>,
}

/// One registered environment.
#[derive(Debug, Clone, Copy)]
pub struct Registration {
    /// Gymnasium id.
    pub id: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// Whether [`EnvOptions::action_dtype`] changes the env's arithmetic.
    pub dtype_sensitive: bool,
}

/// Every built-in environment, in listing order.
pub const REGISTRY: &[Registration] = &[
    Registration {
        id: "CartPole-v0",
        summary: "balance a pole on a cart (Gymnasium CartPole, 200 steps)",
        dtype_sensitive: false,
    },
    Registration {
        id: "CartPole-v1",
        summary: "balance a pole on a cart (Gymnasium CartPole, 500 steps)",
        dtype_sensitive: false,
    },
    Registration {
        id: "Acrobot-v1",
        summary: "swing a two-link arm's tip above a line (Gymnasium Acrobot, 500 steps)",
        dtype_sensitive: false,
    },
    Registration {
        id: "Pendulum-v0",
        summary: "swing a pendulum up and hold it (gym 0.17.2 dynamics and seeding, 200 steps)",
        dtype_sensitive: false,
    },
    Registration {
        id: "Pendulum-v1",
        summary: "swing a pendulum up and hold it (Gymnasium Pendulum, 200 steps)",
        dtype_sensitive: true,
    },
    Registration {
        id: "MountainCar-v0",
        summary: "drive an under-powered car up a hill, 3 discrete pushes (200 steps)",
        dtype_sensitive: false,
    },
    Registration {
        id: "MountainCarContinuous-v0",
        summary: "drive an under-powered car up a hill, continuous force (999 steps)",
        dtype_sensitive: true,
    },
];

/// An id that names no built-in environment.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("unknown environment '{id}'{}; known environments: {}",
    .suggestion.map(|s| format!(" (did you mean '{s}'?)")).unwrap_or_default(),
    known_ids().collect::<Vec<_>>().join(", "))]
pub struct UnknownEnv {
    /// The id asked for.
    pub id: String,
    /// The nearest known id, if any is close.
    pub suggestion: Option<&'static str>,
}

/// Ids of all built-in environments.
pub fn known_ids() -> impl Iterator<Item = &'static str> {
    REGISTRY.iter().map(|r| r.id)
}

/// The registration of `id`, if it is built in.
pub fn registration(id: &str) -> Option<&'static Registration> {
    REGISTRY.iter().find(|r| r.id == id)
}

/// Receives a concrete environment type from [`visit`].
pub trait EnvVisitor {
    /// What the visitor returns.
    type Output;
    /// Called with the environment, already wrapped in [`TimeLimit`].
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output;
}

/// Builds the environment `id` and hands it, with its concrete type, to `v`.
pub fn visit<V: EnvVisitor>(id: &str, opts: &EnvOptions, v: V) -> Result<V::Output, UnknownEnv> {
    let limit = opts.max_episode_steps;
    Ok(match id {
        "CartPole-v0" => v.visit(TimeLimit::new(CartPole::v0(), limit)),
        "CartPole-v1" => v.visit(TimeLimit::new(CartPole::v1(), limit)),
        "Acrobot-v1" => v.visit(TimeLimit::new(Acrobot::new(), limit)),
        "Pendulum-v0" => v.visit(TimeLimit::new(Pendulum::v0(opts.action_dtype), limit)),
        "Pendulum-v1" => v.visit(TimeLimit::new(Pendulum::v1(opts.action_dtype), limit)),
        "MountainCar-v0" => v.visit(TimeLimit::new(MountainCar::new(), limit)),
        "MountainCarContinuous-v0" => v.visit(TimeLimit::new(
            MountainCarContinuous::new(opts.action_dtype),
            limit,
        )),
        _ => {
            return Err(UnknownEnv {
                id: id.to_string(),
                suggestion: rwg_env::suggest::nearest(id, known_ids()),
            })
        }
    })
}

struct Boxer;

impl EnvVisitor for Boxer {
    type Output = Box<dyn Environment + Send>;
    fn visit<E: Environment + Clone + Send + Sync + 'static>(self, env: E) -> Self::Output {
        Box::new(env)
    }
}

/// Builds the environment `id` behind a trait object.
pub fn make(id: &str, opts: &EnvOptions) -> Result<Box<dyn Environment + Send>, UnknownEnv> {
    visit(id, opts, Boxer)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registered_id_builds_with_its_own_id() {
        for r in REGISTRY {
            let env = make(r.id, &EnvOptions::default()).unwrap();
            assert_eq!(env.spec().id, r.id);
        }
    }

    #[test]
    fn unknown_id_suggests_the_nearest() {
        let e = make("CartPol-v1", &EnvOptions::default()).err().unwrap();
        assert_eq!(e.suggestion, Some("CartPole-v1"));
        let msg = e.to_string();
        assert!(msg.contains("did you mean 'CartPole-v1'"), "{msg}");
        assert!(msg.contains("CartPole-v0"), "{msg}");
    }

    #[test]
    fn time_limit_override() {
        let opts = EnvOptions {
            max_episode_steps: Some(7),
            ..Default::default()
        };
        assert_eq!(
            make("CartPole-v0", &opts).unwrap().spec().max_episode_steps,
            Some(7)
        );
    }
}
