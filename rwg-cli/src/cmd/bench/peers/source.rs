//! Which of rwg's envs `rwg bench peers` sets beside gymnax-raw: the
//! built-in envs (float64, Gymnasium's bits, at each SIMD level) or gymnax's
//! own envs run by rwg as `gymnax:` envs (rwg's JAX source: the same gymnax
//! code and float32 arithmetic as the peer, so the two sides differ only in
//! what drives the env). Each source has its workloads, its samples per side
//! and the one-cell manifest `rwg run` gets.

use std::path::Path;

/// A workload: an environment and its hidden layers (no bias).
pub type Workload = (&'static str, &'static [usize]);

/// The peers' workloads for the built-in envs (gymnax-raw runs CartPole-v0
/// as CartPole-v1 with a 200-step limit).
pub const PEER_WORKLOADS: [Workload; 5] = [
    ("CartPole-v0", &[]),
    ("CartPole-v0", &[4, 4]),
    ("Acrobot-v1", &[]),
    ("MountainCarContinuous-v0", &[4, 4]),
    ("Pendulum-v1", &[4]),
];

/// The workloads for `gymnax:` envs: gymnax's ids, the same on both sides.
pub const GYMNAX_WORKLOADS: [Workload; 5] = [
    ("CartPole-v1", &[4, 4]),
    ("CartPole-v1", &[]),
    ("Acrobot-v1", &[]),
    ("MountainCarContinuous-v0", &[4, 4]),
    ("Pendulum-v1", &[4]),
];

/// What gymnax-raw's CPU time counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PeerTime {
    /// Its compiled program's run alone (start-up and compilation excluded).
    Compiled,
    /// Its whole process: Python's start-up, the imports, the compilation,
    /// the run and its CSV, as rwg's side is always measured.
    Whole,
}

impl PeerTime {
    /// How the table says it.
    pub fn label(self) -> &'static str {
        match self {
            PeerTime::Compiled => "compiled run",
            PeerTime::Whole => "whole process",
        }
    }
}

/// One comparison of a sitting: networks per workload on each side and
/// what gymnax-raw's time counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// Networks of rwg's run.
    pub rwg_samples: u64,
    /// Networks of gymnax-raw's run.
    pub peer_samples: u64,
    /// What gymnax-raw's time counts.
    pub peer_time: PeerTime,
}

/// The networks of `--source gymnax`'s whole-process comparison by default
/// (the paper's N).
pub const WHOLE_SAMPLES: u64 = 10_000;

/// The networks of `--source gymnax`'s comparison with gymnax-raw's compiled
/// run by default.
pub const COMPILED_SAMPLES: u64 = 30_000;

/// rwg's side of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// rwg's built-in envs (float64, Gymnasium's numbers), at each `--simd` level.
    Builtin,
    /// gymnax's envs as rwg's `gymnax:` envs (JAX, float32, one worker process
    /// with one XLA thread; its start-up and compilation are in rwg's time).
    Gymnax,
}

impl Source {
    /// The workloads of this source.
    pub fn workloads(self) -> &'static [Workload] {
        match self {
            Source::Builtin => &PEER_WORKLOADS,
            Source::Gymnax => &GYMNAX_WORKLOADS,
        }
    }

    /// The env id of a workload in rwg's manifest.
    pub fn rwg_env(self, env: &str) -> String {
        match self {
            Source::Builtin => env.to_string(),
            Source::Gymnax => format!("gymnax:{env}"),
        }
    }

    /// The comparisons of a sitting. Built-in envs: rwg on `rwg` networks
    /// (default 3000) against gymnax-raw's compiled run on `peer` (default
    /// 1000): rates are compared, so each side gets what takes it seconds.
    /// gymnax's envs: both sides on the same networks, rwg's whole run against
    /// gymnax-raw's whole process on `whole` networks (default
    /// [`WHOLE_SAMPLES`]), then against its compiled run alone on `compiled`
    /// (default [`COMPILED_SAMPLES`]); 0 leaves a comparison out.
    pub fn parts(
        self,
        (rwg, peer): (Option<u64>, Option<u64>),
        (whole, compiled): (Option<u64>, Option<u64>),
    ) -> Vec<Part> {
        match self {
            Source::Builtin => vec![Part {
                rwg_samples: rwg.unwrap_or(3000),
                peer_samples: peer.unwrap_or(1000),
                peer_time: PeerTime::Compiled,
            }],
            Source::Gymnax => [
                (whole.unwrap_or(WHOLE_SAMPLES), PeerTime::Whole),
                (compiled.unwrap_or(COMPILED_SAMPLES), PeerTime::Compiled),
            ]
            .into_iter()
            .filter(|&(n, _)| n > 0)
            .map(|(n, peer_time)| Part {
                rwg_samples: n,
                peer_samples: n,
                peer_time,
            })
            .collect(),
        }
    }

    /// The table's name of rwg's column at SIMD level `level`.
    pub fn column(self, level: &str) -> String {
        match self {
            Source::Builtin => format!("rwg {level}"),
            Source::Gymnax => "rwg gymnax:".to_string(),
        }
    }

    /// The one-cell manifest `rwg run` gets for a workload; `python`, the
    /// peer's interpreter, runs a `gymnax:` env's worker.
    pub fn manifest_text(
        self,
        env: &str,
        hidden: &[usize],
        samples: u64,
        episodes: u32,
        seed: u64,
        python: &Path,
    ) -> String {
        let h: Vec<String> = hidden.iter().map(|x| x.to_string()).collect();
        let name = if hidden.is_empty() {
            "0HL".to_string()
        } else {
            format!("{}HL", hidden.len())
        };
        let mut m = format!(
            "# rwg bench peers: one workload\nseed = {seed}\nsamples = {samples}\n\
             episodes = {episodes}\nbias = [false]\n\n[weights]\ndistribution = \"normal\"\n\
             scale = 1.0\n\n[[architectures]]\nname = \"{name}\"\nhidden = [{}]\n\n\
             [[envs]]\nid = \"{}\"\n",
            h.join(", "),
            self.rwg_env(env)
        );
        if self == Source::Gymnax {
            // a TOML basic string: JSON's escapes are TOML's for a path
            m += &format!(
                "python = {}\n",
                serde_json::to_string(&python.to_string_lossy()).unwrap_or_default()
            );
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_names_the_workload() {
        let py = Path::new("/v/bin/python");
        let t = Source::Builtin.manifest_text("Pendulum-v1", &[4, 4], 3000, 20, 7, py);
        for s in [
            "seed = 7",
            "samples = 3000",
            "episodes = 20",
            "bias = [false]",
            "hidden = [4, 4]",
            "id = \"Pendulum-v1\"",
        ] {
            assert!(t.contains(s), "{s} missing from:\n{t}");
        }
        assert!(!t.contains("python"), "{t}");
        let t = Source::Builtin.manifest_text("CartPole-v0", &[], 1, 1, 0, py);
        assert!(t.contains("hidden = []"), "{t}");
        let t = Source::Gymnax.manifest_text("CartPole-v1", &[4, 4], 5, 2, 0, py);
        assert!(t.contains("id = \"gymnax:CartPole-v1\"\n"), "{t}");
        assert!(t.contains("python = \"/v/bin/python\"\n"), "{t}");
        let odd = Source::Gymnax.manifest_text("Acrobot-v1", &[], 5, 2, 0, Path::new("/a \"b\""));
        assert!(odd.contains(r#"python = "/a \"b\"""#), "{odd}");
    }

    #[test]
    fn workloads_name_envs_of_their_source() {
        for (env, _) in PEER_WORKLOADS {
            assert!(rwg_envs::registry::registration(env).is_some(), "{env}");
        }
        // gymnax's registered ids (gymnax.registered_envs) among the classic ones
        let gymnax = [
            "CartPole-v1",
            "Pendulum-v1",
            "Acrobot-v1",
            "MountainCar-v0",
            "MountainCarContinuous-v0",
        ];
        for (env, _) in GYMNAX_WORKLOADS {
            assert!(gymnax.contains(&env), "{env}");
        }
        assert_eq!(GYMNAX_WORKLOADS[0], ("CartPole-v1", &[4usize, 4][..]));
        assert_eq!(Source::Gymnax.rwg_env("Acrobot-v1"), "gymnax:Acrobot-v1");
        assert_eq!(Source::Builtin.rwg_env("Acrobot-v1"), "Acrobot-v1");
    }

    #[test]
    fn gymnax_compares_whole_processes_then_the_compiled_run() {
        let parts = Source::Gymnax.parts((None, None), (None, None));
        let got: Vec<_> = parts
            .iter()
            .map(|p| (p.rwg_samples, p.peer_samples, p.peer_time))
            .collect();
        assert_eq!(
            got,
            [
                (10_000, 10_000, PeerTime::Whole),
                (30_000, 30_000, PeerTime::Compiled)
            ]
        );
        let only_whole = Source::Gymnax.parts((None, None), (Some(64), Some(0)));
        assert_eq!(only_whole.len(), 1);
        assert_eq!(only_whole[0].rwg_samples, 64);
        let builtin = Source::Builtin.parts((Some(6), None), (None, None));
        assert_eq!(
            builtin,
            [Part {
                rwg_samples: 6,
                peer_samples: 1000,
                peer_time: PeerTime::Compiled
            }]
        );
    }
}
