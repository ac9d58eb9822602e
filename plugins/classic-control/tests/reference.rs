//! Loads the built reference plugin and checks that every exported
//! environment reproduces its built-in twin bit for bit.
//!
//! The library is found next to this test binary's directory: cargo builds
//! the package's cdylib before its integration tests, into
//! `$CARGO_TARGET_DIR/<profile>/`, and the test runs from
//! `$CARGO_TARGET_DIR/<profile>/deps/`.

use std::path::PathBuf;

use rwg_env::{Action, ActionDtype, Environment, Space};
use rwg_envs::{make, EnvOptions, REGISTRY};
use rwg_plugin_host::{check_plugin_env, library_file_name, load_plugin, CheckStatus, Plugin};

fn plugin_path() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let file = library_file_name("rwg_plugin_classic_control");
    [deps.parent().unwrap(), deps]
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "{file} not found near {}: run `cargo build -p rwg-plugin-classic-control`",
                deps.display()
            )
        })
}

fn plugin() -> Plugin {
    load_plugin(plugin_path()).unwrap()
}

/// xorshift: a fixed action sequence per seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One full episode (until terminated or truncated), recorded as bits.
fn episode<E: Environment>(env: &mut E, seed: u64) -> Vec<u64> {
    let spec = env.spec().clone();
    let mut obs = vec![0.0; spec.obs_dim()];
    let mut rec = Vec::new();
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    env.reset(seed, &mut obs).unwrap();
    rec.extend(obs.iter().map(|x| x.to_bits()));
    loop {
        let action: Vec<f64>;
        let a = match &spec.action_space {
            Space::Discrete { n } => Action::Discrete((rng.next() % *n as u64) as i64),
            Space::Box(b) => {
                // Up to 50% beyond the bounds, so clipping is exercised too.
                action = b
                    .low
                    .iter()
                    .zip(&b.high)
                    .map(|(lo, hi)| lo + (hi - lo) * (2.0 * rng.unit() - 0.5))
                    .collect();
                Action::Continuous(&action)
            }
        };
        let s = env.step(a, &mut obs).unwrap();
        rec.extend(obs.iter().map(|x| x.to_bits()));
        rec.push(s.reward.to_bits());
        rec.push(u64::from(s.terminated) | u64::from(s.truncated) << 1);
        if s.terminated || s.truncated {
            return rec;
        }
    }
}

#[test]
fn exports_every_registered_env_with_the_built_in_spec() {
    let p = plugin();
    assert_eq!(p.id(), "classic_control");
    assert_eq!(p.envs().len(), REGISTRY.len());
    for r in REGISTRY {
        let ty = p
            .env(&format!("classic_control/{}", r.id))
            .unwrap_or_else(|| panic!("{} not exported", r.id));
        let mut want = make(r.id, &EnvOptions::default()).unwrap().spec().clone();
        want.id = ty.id().to_string();
        assert_eq!(ty.spec(), &want);
        assert_eq!(ty.summary(), r.summary);
    }
}

#[test]
fn cartpole_v0_reproduces_the_built_in_trajectories_exactly() {
    let p = plugin();
    let ty = p.env("classic_control/CartPole-v0").unwrap();
    let mut plugin_env = ty.make("", None).unwrap();
    let mut builtin = make("CartPole-v0", &EnvOptions::default()).unwrap();
    for seed in [0, 1, 42, 12345, u64::MAX] {
        assert_eq!(
            episode(&mut plugin_env, seed),
            episode(&mut builtin, seed),
            "seed {seed}"
        );
    }
}

#[test]
fn every_registered_env_reproduces_the_built_in_trajectories() {
    let p = plugin();
    for r in REGISTRY {
        let ty = p.env(&format!("classic_control/{}", r.id)).unwrap();
        let dtypes: &[(ActionDtype, &str)] = if r.dtype_sensitive {
            &[
                (ActionDtype::F64, ""),
                (ActionDtype::F32, "action_dtype=float32"),
            ]
        } else {
            &[(ActionDtype::F64, "")]
        };
        for &(dtype, config) in dtypes {
            let opts = EnvOptions {
                action_dtype: dtype,
                ..Default::default()
            };
            let mut builtin = make(r.id, &opts).unwrap();
            let mut plugin_env = ty.make(config, None).unwrap();
            for seed in 0..4 {
                assert_eq!(
                    episode(&mut plugin_env, seed),
                    episode(&mut builtin, seed),
                    "{} {config:?} seed {seed}",
                    r.id
                );
            }
        }
    }
}

#[test]
fn config_is_validated() {
    let p = plugin();
    let ty = p.env("classic_control/CartPole-v0").unwrap();
    assert!(ty.create("action_dtype=float32").is_ok());
    let msg = ty.create("colour=blue").unwrap_err().to_string();
    assert!(msg.contains("unknown config item 'colour=blue'"), "{msg}");
}

#[test]
fn the_checker_passes_every_env() {
    let p = plugin();
    for ty in p.envs() {
        let results = check_plugin_env(ty, "");
        let failed: Vec<String> = results
            .iter()
            .filter(|r| r.status == CheckStatus::Failed)
            .map(|r| r.to_string())
            .collect();
        assert!(failed.is_empty(), "{failed:#?}");
    }
}
