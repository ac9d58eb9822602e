//! An example rwg plugin: a point mass on a plane that must reach a target.
//!
//! Two environments, to show both kinds of action space:
//!
//! - `example/PointMass-v0`: continuous force `[fx, fy]` in `[-1, 1]²`
//!   (values outside are clipped).
//! - `example/PointMassDiscrete-v0`: 5 actions: none, +x, -x, +y, -y.
//!
//! Observation `[x, y, vx, vy, tx, ty]`: position, velocity and target. The
//! arena is `[-1, 1]²` with walls; the speed is at most 1 per axis. Each step
//! costs the distance to the target; reaching it (distance < `radius`)
//! terminates the episode with a bonus of 10. Episodes are limited to 200
//! steps (the host applies the limit).
//!
//! Config string: comma-separated `key=value` pairs, `mass=<f64>` (default 1)
//! and `radius=<f64>` (default 0.05), e.g. `"mass=2,radius=0.1"`.
//!
//! The plugin itself is the last line: [`rwg_env::export_plugin!`] with a
//! [`PluginBuilder`] listing the environments.

use rwg_env::env::{continuous_action, discrete_action};
use rwg_env::plugin::PluginBuilder;
use rwg_env::seeding::Pcg64;
use rwg_env::{Action, BoxSpace, EnvError, EnvSpec, Environment, Space, Step};

const DT: f64 = 0.05;
const DAMPING: f64 = 0.1;
const MAX_SPEED: f64 = 1.0;
const ARENA: f64 = 1.0;
const BONUS: f64 = 10.0;

/// Parameters set by the config string.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Mass of the point (force / mass = acceleration).
    pub mass: f64,
    /// Distance to the target that counts as reached.
    pub radius: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            mass: 1.0,
            radius: 0.05,
        }
    }
}

impl Params {
    /// Parses `"mass=2,radius=0.1"` (any subset, any order; `""` = defaults).
    pub fn parse(config: &str) -> Result<Params, String> {
        let mut p = Params::default();
        for item in config.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| format!("config item '{item}' is not key=value"))?;
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| format!("config {key}: '{value}' is not a number"))?;
            match key.trim() {
                "mass" if v > 0.0 && v.is_finite() => p.mass = v,
                "radius" if v > 0.0 && v.is_finite() => p.radius = v,
                "mass" | "radius" => return Err(format!("config {key} must be positive, got {v}")),
                k => return Err(format!("unknown config key '{k}' (known: mass, radius)")),
            }
        }
        Ok(p)
    }
}

/// The point-mass task; `discrete` selects the action space.
#[derive(Debug, Clone)]
pub struct PointMass {
    spec: EnvSpec,
    params: Params,
    discrete: bool,
    /// `[x, y, vx, vy, tx, ty]`.
    state: [f64; 6],
    started: bool,
}

impl PointMass {
    /// The spec of the continuous (`discrete = false`) or discrete variant.
    pub fn spec(discrete: bool) -> EnvSpec {
        let high = [ARENA, ARENA, MAX_SPEED, MAX_SPEED, ARENA, ARENA];
        EnvSpec {
            id: if discrete {
                "example/PointMassDiscrete-v0".into()
            } else {
                "example/PointMass-v0".into()
            },
            observation_space: Space::Box(BoxSpace::symmetric(&high)),
            action_space: if discrete {
                Space::Discrete { n: 5 }
            } else {
                Space::Box(BoxSpace::symmetric(&[1.0, 1.0]))
            },
            max_episode_steps: Some(200),
            reward_threshold: None,
        }
    }

    /// A new instance (reset it before stepping).
    pub fn new(discrete: bool, params: Params) -> PointMass {
        PointMass {
            spec: PointMass::spec(discrete),
            params,
            discrete,
            state: [0.0; 6],
            started: false,
        }
    }

    fn distance(&self) -> f64 {
        let [x, y, _, _, tx, ty] = self.state;
        (x - tx).hypot(y - ty)
    }
}

impl Environment for PointMass {
    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64, obs: &mut [f64]) -> Result<(), EnvError> {
        // Everything random comes from the seed: same seed, same episode.
        let mut rng = Pcg64::from_seed(seed);
        let mut u = || rng.uniform(-0.9, 0.9);
        self.state = [u(), u(), 0.0, 0.0, u(), u()];
        self.started = true;
        obs.copy_from_slice(&self.state);
        Ok(())
    }

    fn step(&mut self, action: Action<'_>, obs: &mut [f64]) -> Result<Step, EnvError> {
        if !self.started {
            return Err(EnvError::ResetNeeded);
        }
        let force = if self.discrete {
            match discrete_action(action, 5)? {
                0 => [0.0, 0.0],
                1 => [1.0, 0.0],
                2 => [-1.0, 0.0],
                3 => [0.0, 1.0],
                _ => [0.0, -1.0],
            }
        } else {
            let a = continuous_action(action, 2)?;
            // (The export shim already refuses non-finite actions; checking
            // here too keeps the env correct when used directly.)
            if a.iter().any(|x| !x.is_finite()) {
                return Err(EnvError::InvalidAction(format!("non-finite action {a:?}")));
            }
            [a[0].clamp(-1.0, 1.0), a[1].clamp(-1.0, 1.0)]
        };
        let s = &mut self.state;
        for i in 0..2 {
            let v = s[2 + i] * (1.0 - DAMPING) + force[i] / self.params.mass * DT;
            s[2 + i] = v.clamp(-MAX_SPEED, MAX_SPEED);
            s[i] += s[2 + i] * DT;
            if s[i].abs() > ARENA {
                // A wall: stop at it.
                s[i] = s[i].clamp(-ARENA, ARENA);
                s[2 + i] = 0.0;
            }
        }
        let d = self.distance();
        let reached = d < self.params.radius;
        obs.copy_from_slice(&self.state);
        Ok(Step {
            reward: -d + if reached { BONUS } else { 0.0 },
            terminated: reached,
            truncated: false,
        })
    }
}

/// The plugin's description: id, version and environments.
pub fn plugin() -> PluginBuilder {
    PluginBuilder::new("example", env!("CARGO_PKG_VERSION"))
        .env(
            PointMass::spec(false),
            "push a point mass to a target (continuous force)",
            |config: &str| Params::parse(config).map(|p| PointMass::new(false, p)),
        )
        .env(
            PointMass::spec(true),
            "push a point mass to a target (5 discrete pushes)",
            |config: &str| Params::parse(config).map(|p| PointMass::new(true, p)),
        )
}

// Defines the exported `rwg_plugin_entry_v1`.
rwg_env::export_plugin!(plugin());

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_parsing() {
        assert_eq!(Params::parse(""), Ok(Params::default()));
        assert_eq!(
            Params::parse("radius=0.1, mass=2"),
            Ok(Params {
                mass: 2.0,
                radius: 0.1
            })
        );
        assert!(Params::parse("mass=-1").is_err());
        assert!(Params::parse("mass").is_err());
        assert!(Params::parse("speed=1")
            .unwrap_err()
            .contains("unknown config key"));
    }

    #[test]
    fn the_checker_passes_both_envs_in_process() {
        for discrete in [false, true] {
            let results = rwg_plugin_host::check_env(|| {
                Params::parse("").map(|p| PointMass::new(discrete, p))
            });
            let failed: Vec<_> = results
                .iter()
                .filter(|r| r.status == rwg_plugin_host::CheckStatus::Failed)
                .collect();
            assert!(failed.is_empty(), "{failed:#?}");
        }
    }
}
