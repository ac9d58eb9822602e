//! # rwg-envs
//!
//! Gymnasium's classic-control environments, reproducing Gymnasium 1.4's
//! numbers bit for bit (and gym 0.17.2's for Pendulum-v0). Each env lives in
//! its own module; [`registry`] builds them by id with Gymnasium's time limits.
//!
//! # Example
//!
//! An env by its Gymnasium id, wrapped in its time limit, stepped with the
//! seed and actions Gymnasium would get (`env.reset(seed=0)`, then
//! `env.step(1)` until the episode ends):
//!
//! ```
//! use rwg_env::{Action, Environment};
//! use rwg_envs::{make, EnvOptions};
//!
//! let mut env = make("CartPole-v1", &EnvOptions::default())?;
//! assert_eq!(env.spec().max_episode_steps, Some(500));
//! let mut obs = vec![0.0; env.spec().obs_dim()];
//! env.reset(0, &mut obs)?;
//! let mut score = 0.0;
//! loop {
//!     let s = env.step(Action::Discrete(1), &mut obs)?;
//!     score += s.reward;
//!     if s.terminated || s.truncated {
//!         break;
//!     }
//! }
//! // Always pushing right tips the pole over within a few dozen steps.
//! assert!(score > 0.0 && score < 50.0, "{score}");
//! assert!(make("CartPole-v2", &EnvOptions::default()).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//!
//! - One module per env ([`cartpole`], [`acrobot`], [`pendulum`],
//!   [`mountain_car`], [`mountain_car_continuous`]), their state through
//!   `array_state!`.
//! - [`registry`]: ids, time limits and reward thresholds, static dispatch
//!   through [`visit`].
//! - [`lockstep`]: each env again over N lanes as a `ManyEnv`: state as arrays
//!   over lanes, one `lanes_math` call per libm use, Gymnasium's `TimeLimit` per
//!   lane; `visit_lockstep` hands out the concrete type. `wide.rs` compiles each
//!   step body again for AVX2 and for AVX-512, the level chosen at run time by
//!   `rwg_env::simd::level` (the same operations, so the same bits;
//!   `RWG_SIMD=scalar` for the baseline). Lane loops
//!   combine booleans with `&`/`|` so they stay branch-free, and the step bodies
//!   take the per-lane buffers as arrays of the lane count (`lane_arrays`: one
//!   length check per call).

/// The `state_len`, `state` and `set_state` methods of an environment
/// whose internal state is the array `self.state: [f64; N]` (Gymnasium's
/// `env.unwrapped.state`), written once for every env here. `set_state`
/// copies the state in, then runs the given block with `$env` bound to
/// `&mut self` and `$obs` to the observation buffer: the env resets its
/// episode flags and writes the observation there.
macro_rules! array_state {
    ($n:expr, |$env:ident, $obs:ident| $after:block) => {
        fn state_len(&self) -> usize {
            $n
        }

        fn state(&self, out: &mut [f64]) -> Result<(), EnvError> {
            rwg_env::env::check_state_len(out, $n)?;
            out.copy_from_slice(&self.state);
            Ok(())
        }

        fn set_state(&mut self, state: &[f64], $obs: &mut [f64]) -> Result<(), EnvError> {
            rwg_env::env::check_state_len(state, $n)?;
            self.state.copy_from_slice(state);
            let $env = self;
            $after
            Ok(())
        }
    };
}

pub mod acrobot;
pub mod cartpole;
pub mod lockstep;
pub mod mountain_car;
pub mod mountain_car_continuous;
pub mod pendulum;
pub mod registry;

pub use lockstep::{visit_lockstep, LockstepEnv, LockstepVisitor};
pub use registry::{make, visit, EnvOptions, EnvVisitor, Registration, UnknownEnv, REGISTRY};
