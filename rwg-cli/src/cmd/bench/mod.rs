//! `rwg bench`: throughput of the built-in environments and of the RWG sampler.
//!
//! Two measurements, both statically dispatched through [`rwg_envs::visit`]
//! (the step loop is monomorphised for each concrete env type):
//!
//! - `rwg bench envs`: raw `Environment::step` throughput under a fixed,
//!   pre-generated pseudo-random action sequence, resetting with successive
//!   seeds whenever an episode ends;
//! - `rwg bench sampler`: the whole RWG workload (weight draws, reset seed
//!   derivation, resets, policy forward pass, env steps) through
//!   [`rwg_core::sampler::run_cell`], for the configurations the peer
//!   implementations were measured on.
//!
//! Every figure comes from one timed run; the machine's noise is not averaged
//! out. Env steps are counted exactly: every step of every episode. The
//! comparison with the peers, by contrast, measures both sides in the same
//! invocation: `rwg bench peers` ([`peers`]).
//!
//! One file per benchmark: `envs` (built-in envs), `plugin` (a plugin's
//! envs against the built-ins they re-export), `plugin_sampler` (`rwg bench
//! plugin`: the RWG workload on a plugin's single calls, batched calls and
//! vector env against the built-ins), `sampler` (the RWG workload), `peers` (the whole `rwg run` against gymnax-raw, side by
//! side), `gym` (Gymnasium envs through the bridge against a pure-Python
//! loop), `libm` (`rwg_env::lanes_math`'s vector sin/cos and pow against libm, bits
//! and speed); the timing and the table output are shared, here.

mod envs;
mod gym;
mod libm;
mod peers;
mod plugin;
mod plugin_sampler;
mod sampler;

use anyhow::Result;
use rwg_analysis::table::{Align, TextColumns};
use rwg_envs::EnvOptions;
use std::time::Instant;

/// Arguments of `rwg bench`.
#[derive(clap::Args)]
#[command(after_help = "\
`envs` and `sampler` run in this process and report one timed run; repeat them to \
see the noise. `peers` runs rwg and a peer as child processes, interleaved, and \
reports medians with their spread. Build with --release for meaningful figures.")]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// Raw environment steps per second under a fixed pseudo-random action sequence.
    #[command(after_help = "\
Measures Environment::step alone (plus the resets between episodes): for each env, a \
sequence of 4096 pseudo-random actions (discrete: uniform integers; continuous: uniform \
within the action bounds) is generated before timing and replayed cyclically. When an \
episode terminates or is truncated by the time limit, the env is reset with the next \
seed (0, 1, 2, ...); the resets are inside the timed span. No policy is evaluated.

Columns: steps = env steps timed, episodes = episodes started, steps/s and ns/step (wall \
clock), steps/CPU-s (process CPU time: steadier on a busy machine), and the sum of all \
rewards. With --hash, a hash of the bits of every observation and reward follows: it \
must be the same for every build (on the same libm) for the same --steps (the envs \
are bit-exact), so it checks that an optimisation changed no result.")]
    Envs(envs::EnvsArgs),
    /// The RWG workload (env + policy) through the sampler alone.
    #[command(after_help = "\
Measures what `rwg` spends its time on: for each configuration, SAMPLES networks with \
i.i.d. N(0,1) weights (no bias) each run EPISODES episodes through rwg_core's sampler \
(weight draws, reset seeds, resets, policy forward passes and env steps, on a rayon \
pool of THREADS threads). Reported: env steps (every step of every episode), wall \
time, env steps/s in total and per thread, and env steps per CPU-second of the process \
(steadier than wall time on a busy machine). The sampler alone is not the whole `rwg \
run` command: compare with other implementations with `rwg bench peers`, which \
measures both sides in one invocation. Each thread runs several episodes side by side \
(the JSON's `lanes`), stepped as `rwg run` steps built-in envs: all lanes in one call \
(lockstep; RWG_LOCKSTEP=0 for one env instance per lane; the JSON's `path`); the results \
are those of running them one by one (`mean_score` does not depend on the build, the \
thread count, the lanes or the path).

Configurations (the peers' workload): CartPole-v0 0HL, CartPole-v0 [4,4], Acrobot-v1 \
0HL, MountainCarContinuous-v0 [4,4], Pendulum-v1 [4].")]
    Sampler(sampler::SamplerArgs),
    /// The whole `rwg run --threads 1` against gymnax-raw, side by side, pinned to one core.
    #[command(after_help = "\
For each of the peers' five workloads (CartPole-v0 0HL, CartPole-v0 [4,4], Acrobot-v1 \
0HL, MountainCarContinuous-v0 [4,4], Pendulum-v1 [4]; no bias), runs ROUNDS times, \
interleaved (alternating which side goes first), with this process and its children \
pinned to one core:
  - `rwg run --threads 1` on a one-cell manifest (RWG_SAMPLES networks x EPISODES \
episodes, the report included): the child's whole CPU time (getrusage);
  - gymnax-raw (`gymnax_rwg.py --step raw` of the peer scripts, PEER_SAMPLES networks): \
the CPU time its JSON reports for the compiled run (JAX start-up and XLA compile \
excluded, as the peer reports them apart).
Prints env steps per CPU-second of each side and their ratio per round: median \
[min-max]. Env steps are the transitions inside episodes on both sides.

rwg runs at the SIMD level it would run at (RWG_SIMD, else AVX2 where the CPU has it), or at \
each level --simd lists: then every round runs rwg once per level (its RWG_SIMD set to \
it) beside the peer, rwg first in the listed order or the peer first and the levels \
reversed, alternately; the table gets a column of rwg's rates and of its ratio to \
gymnax-raw per level, and the last level's rate over the first's, paired by round. \
Every level must score each workload identically (checked); a level this CPU lacks is \
an error. --json keeps every measurement with its level.

--source gymnax sets rwg's JAX source beside the peer instead: gymnax's own envs as rwg's \
`gymnax:` envs (CartPole-v1 [4,4], CartPole-v1 0HL, Acrobot-v1 0HL, \
MountainCarContinuous-v0 [4,4], Pendulum-v1 [4]; the same ids on both sides, float32), \
rwg's worker started with the peer's Python. rwg's CPU time is then the whole command's \
with its JAX worker process: JAX's start-up and the XLA compilation are in it, unlike \
the peer's. Both sides default to 100000 networks.

The peer scripts are the repository's benches/peers (--peers, relative to the current \
directory: run from the repository's top folder). The peer needs a Python with jax and \
gymnax: --python (or RWG_PEER_PYTHON), or the virtualenv --venv, which --create-venv \
makes as the first two examples do. Build rwg with --release for meaningful figures; \
benches/peers/README.md has the other peers (the paper's numpy way, Gymnasium's vector \
envs, EnvPool).

Examples:
  python3 -m venv target/peers-venv
  target/peers-venv/bin/pip install numpy==2.4.6 gymnasium==1.3.0 jax==0.10.2 jaxlib==0.10.2 \\
    gymnax==1.0.1 flax==0.12.8 six==1.17.0
  rwg bench peers
  rwg bench peers --simd avx2,avx512 --env Pendulum-v1   # on a CPU with AVX-512
  rwg bench peers --source gymnax --env CartPole-v1 --rounds 3")]
    Peers(peers::PeersArgs),
    /// Gymnasium envs through the bridge, beside a pure-Python ceiling loop and a peer script.
    #[command(after_help = "\
For each gymnasium: env, interleaved REPEATS times: (1) the RWG workload (SAMPLES 0HL \
networks x EPISODES episodes, no bias) through the bridge on one sampler thread = one \
Python worker; (2) a pure-Python loop in one process that only calls env.step with \
pre-drawn random actions for the same number of steps (resetting with successive seeds), \
the ceiling for any bridge; (3) the same RWG workload on two threads = two workers; \
(4) with --peer, a peer script on SAMPLES/5 networks. Worker start-up is not timed. \
Reported: median [min-max] env steps/s, bridge / ceiling and 2 workers / 1 worker.

Example:
  rwg bench gym --env gymnasium:CartPole-v1 --peer benches/peers/ref_numpy.py")]
    Gym(gym::GymBenchArgs),
    /// A plugin's re-exported classic envs in the sampler: built-in vs the plugin's single calls, batched calls and vector env.
    #[command(after_help = "\
For each built-in env the plugin re-exports as NAMESPACE/ID and each of the paper's \
architectures (0HL, [4], [4,4]; no bias), ROUNDS interleaved rounds (the order rotating) of \
the RWG workload (SAMPLES networks x EPISODES episodes, seeded with the built-in id so all \
five run the same episodes, checked) on one sampler thread in this process: (1) the \
built-in env, one instance per lane, as `rwg run` with RWG_LOCKSTEP=0; (2) the plugin \
through its single calls, as `rwg run` with RWG_PLUGIN_BATCH=0; (3) the plugin through ABI \
1.1's batched calls, as `rwg run` with RWG_PLUGIN_VEC=0; (4) the built-in env in lockstep, \
as `rwg run` by default; (5) the plugin through ABI 1.2's vector env, as `rwg run` by \
default (not run for an env without one). --only and --arch run one variant and \
architecture alone (e.g. under callgrind). Reported: process CPU ns per env step, median \
[min-max], the per-round ratios to the built-in (1), and the batched plugin's and the \
vector env's to the lockstep built-in (3 / 4, 5 / 4). Build with --release for meaningful \
figures.

Example:
  rwg bench plugin --plugin target/release/librwg_plugin_classic_control.so")]
    Plugin(plugin_sampler::PluginArgs),
    /// The vector sin/cos and pow(x, 2) of the lockstep envs against this machine's libm: bits
    /// and speed.
    #[command(after_help = "\
rwg_env::lanes_math computes sin and cos four lanes at a time with AVX2+FMA or eight with \
AVX-512 (the level RWG_SIMD picks, else AVX2 where the CPU has it), a port of glibc 2.36's \
__sin_fma/__cos_fma meant to return exactly libm's bits, and Python's x**2 (libm pow(x, \
2)) as x*x where the exact square is within 0.48 ulp of it, else by a port of glibc \
2.36's __pow_fma; each level is used only when its one-time self-check on some thousands \
of edge arguments passes. This command checks every level the CPU has on many more. \
sin/cos: the fixed edge set plus N pseudo-random arguments split evenly over CartPole's \
|x| < 0.3, MountainCarContinuous' |x| <= 3.6, Acrobot's |x| <= 20, Pendulum's |x| <= 200 and a \
log-uniform sweep 2^-30 <= |x| < 105414350 (every path of the vector code), comparing \
sin, cos and sincos (both halves) with one libm sin and one libm cos call per argument. \
pow: its edge set plus N (or --pow-check's) arguments split evenly over the envs' \
|x| <= 30, the hard squares only (the ones the port computes) and a log-uniform sweep of \
the port's range 2^-60 <= |x| <= 2^32, comparing the port alone (on every argument) and \
pow2_lanes with one libm pow call per argument. Differing results are printed \
(argument, libm's bits, the vector's bits) and make the command fail. Then, for each \
range, the CPU time per element of libm (one call per element) and of each level's \
vector code on 16-lane slices, ROUNDS interleaved rounds: median [min-max]. Build with \
--release: a debug build checks the same bits, slowly.

Examples:
  rwg bench libm --check 1000000000 --rounds 0   # 10^9 arguments each, several minutes
  rwg bench libm --check 0 --pow-check 1000000000 --rounds 0   # only pow, 10^9 arguments")]
    Libm(libm::LibmArgs),
}

/// Runs `rwg bench`.
pub fn run(args: Args) -> Result<()> {
    match args.what {
        What::Envs(a) => envs::run(a),
        What::Sampler(a) => sampler::run(a),
        What::Peers(a) => peers::run(a),
        What::Gym(a) => gym::run(a),
        What::Plugin(a) => plugin_sampler::run(a),
        What::Libm(a) => libm::run(a),
    }
}

/// Checks `--env` ids against the registry (with a suggestion for typos).
pub(super) fn check_ids(ids: &[String]) -> Result<()> {
    for id in ids {
        rwg_envs::make(id, &EnvOptions::default())?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// timing

/// Wall clock and process CPU time of a timed span.
pub(super) struct Clock {
    wall: Instant,
    cpu: Option<f64>,
}

impl Clock {
    pub(super) fn start() -> Clock {
        Clock {
            cpu: process_cpu_seconds(),
            wall: Instant::now(),
        }
    }

    /// (wall seconds, CPU seconds) since `start`.
    pub(super) fn stop(self) -> (f64, Option<f64>) {
        let wall = self.wall.elapsed().as_secs_f64();
        let cpu = process_cpu_seconds().zip(self.cpu).map(|(b, a)| b - a);
        (wall, cpu)
    }
}

/// CPU time of this process (all threads) in seconds, where measurable.
fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec for the call's duration.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
        (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

// ---------------------------------------------------------------------------
// statistics of repeated measurements

/// Median, min and max of `v` (`(NaN, NaN, NaN)` for no values): what every
/// bench reports of its rounds.
pub(super) fn spread(v: &[f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let median = if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    };
    (median, s[0], s[n - 1])
}

// ---------------------------------------------------------------------------
// table output

/// Prints one table line: each cell padded to its column's width (a negative
/// width left-aligns), columns separated by two spaces. Rows are printed as
/// soon as they are measured, so the widths are fixed in advance.
pub(super) fn print_row<const N: usize>(columns: &[(&str, i32); N], cells: &[String; N]) {
    let columns: Vec<(usize, Align)> = columns
        .iter()
        .map(|&(_, w)| {
            let align = if w < 0 { Align::Left } else { Align::Right };
            (w.unsigned_abs() as usize, align)
        })
        .collect();
    crate::outln!("{}", TextColumns::new(&columns, "  ").line(cells));
}

/// `1234567` -> `1,234,567`.
pub(super) fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_is_median_min_max() {
        assert_eq!(spread(&[3.0, 1.0, 2.0]), (2.0, 1.0, 3.0));
        assert_eq!(spread(&[4.0, 1.0, 2.0, 3.0]), (2.5, 1.0, 4.0));
        assert!(spread(&[]).0.is_nan());
    }

    #[test]
    fn digit_grouping() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1,000");
        assert_eq!(group(8_774_515), "8,774,515");
    }
}
