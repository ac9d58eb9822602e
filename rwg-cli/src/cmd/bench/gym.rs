//! `rwg bench gym`: the Gymnasium bridge's throughput, measured side by side
//! with a pure-Python loop stepping the same env (the ceiling) and with the
//! paper's way of running RWG in Python (a peer script such as
//! `benches/peers/ref_numpy.py` of rwg's repository), in one invocation.

use anyhow::{bail, Context, Result};
use rwg_analysis::table::{Align, TextColumns};
use rwg_core::policy::Architecture;
use rwg_core::sampler::{BlockResult, CellPlan, SampleError, WeightDist};
use rwg_gym::GymSource;
use serde::Serialize;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

/// Arguments of `rwg bench gym`.
#[derive(clap::Args)]
pub struct GymBenchArgs {
    /// gymnasium: envs to measure (repeatable).
    #[arg(long = "env", value_name = "ID", default_values_t = ["gymnasium:CartPole-v1".to_string(), "gymnasium:InvertedPendulum-v5".to_string()])]
    envs: Vec<String>,
    /// Networks per measurement (0HL, no bias, N(0,1) weights).
    #[arg(long, default_value_t = 1000)]
    samples: u64,
    /// Episodes per network.
    #[arg(long, default_value_t = 5)]
    episodes: u32,
    /// Measurements of each kind, interleaved; medians and ranges are reported.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// A peer script run as `PYTHON SCRIPT --env ID --samples N --episodes E
    /// --out CSV` that prints a JSON line with `steps_per_s` (e.g.
    /// benches/peers/ref_numpy.py: the paper's way, numpy forward pass and
    /// one env.step per time step in one process).
    #[arg(long, value_name = "SCRIPT")]
    peer: Option<PathBuf>,
    #[command(flatten)]
    gym: crate::gym::GymArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// The ceiling: gym.make, then env.step with pre-drawn random actions
/// (reset with successive seeds when an episode ends), nothing else.
const CEILING_PY: &str = r#"
import json, sys, time
import numpy as np
import gymnasium as gym
env_id, kwargs, n, seed = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
env = gym.make(env_id, **kwargs)
space = env.action_space
rng = np.random.default_rng(seed)
if isinstance(space, gym.spaces.Discrete):
    acts = [int(a) for a in rng.integers(space.n, size=4096) + space.start]
else:
    acts = [np.asarray(rng.uniform(space.low, space.high), dtype=np.float64) for _ in range(4096)]
env.reset(seed=seed)
s = 1
t = time.perf_counter()
c = time.process_time()
for i in range(n):
    obs, r, term, trunc, _ = env.step(acts[i & 4095])
    if term or trunc:
        env.reset(seed=seed + s)
        s += 1
print(json.dumps({"steps": n, "wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c}))
"#;

#[derive(Serialize, Default)]
struct Row {
    env: String,
    /// Env steps per wall-clock second, one per repeat.
    ceiling: Vec<f64>,
    bridge_1_worker: Vec<f64>,
    bridge_2_workers: Vec<f64>,
    peer: Vec<f64>,
    /// Env steps per CPU-second (all processes involved), one per repeat.
    ceiling_cpu: Vec<f64>,
    bridge_1_worker_cpu: Vec<f64>,
    bridge_2_workers_cpu: Vec<f64>,
    peer_cpu: Vec<f64>,
    steps_per_run: u64,
}

fn median(v: &[f64]) -> f64 {
    super::spread(v).0
}

fn fmt_stat(v: &[f64]) -> String {
    if v.is_empty() {
        return "-".into();
    }
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    format!("{:.0} [{:.0}-{:.0}]", median(v), lo, hi)
}

/// CPU time of this process (all threads) in seconds.
fn own_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the call's duration.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Runs the RWG workload through the bridge on `threads` threads; returns
/// (env steps, wall seconds, CPU seconds of rwg and its worker processes).
fn bridge_run(
    src: &GymSource,
    plan: &CellPlan,
    samples: u64,
    threads: usize,
) -> Result<(u64, f64, f64)> {
    let cpu0 = own_cpu_seconds() + src.workers_cpu_seconds().unwrap_or(f64::NAN);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let blocks = rwg_core::sampler::blocks(0..samples, 32);
    let mut steps = 0u64;
    let t = Instant::now();
    pool.install(|| {
        src.run_blocks(plan, &blocks, threads * 2, |b: BlockResult| {
            steps += b.episodes.iter().map(|e| e.steps as u64).sum::<u64>();
            Ok::<(), SampleError>(())
        })
    })?;
    let wall = t.elapsed().as_secs_f64();
    let cpu = own_cpu_seconds() + src.workers_cpu_seconds().unwrap_or(f64::NAN) - cpu0;
    Ok((steps, wall, cpu))
}

fn python_json(cmd: &mut Command) -> Result<serde_json::Value> {
    let out = cmd.output().context("cannot run Python")?;
    if !out.status.success() {
        bail!("{}", String::from_utf8_lossy(&out.stderr));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text.lines().last().unwrap_or_default();
    serde_json::from_str(last).with_context(|| format!("not a JSON line: {last}"))
}

/// Runs `rwg bench gym`.
pub fn run(args: GymBenchArgs) -> Result<()> {
    let mut rows = vec![];
    for id in &args.envs {
        let row = measure_env(&args, id)?;
        if !args.json {
            print_env(&args, &row);
        }
        rows.push(row);
    }
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&rows)?);
    }
    Ok(())
}

/// The measurements of env `id`: after an untimed warm-up, `--repeats`
/// times the ceiling, the bridge with 1 and 2 workers, and the peer script.
fn measure_env(args: &GymBenchArgs, id: &str) -> Result<Row> {
    let cfg = args.gym.config(id)?;
    let src = GymSource::open(cfg.clone()).map_err(|e| anyhow::anyhow!("{id}: {e}"))?;
    let gid = rwg_gym::gym_id(id).expect("a gymnasium: id").to_string();
    let plan = CellPlan {
        seed: 0,
        env_id: gid.clone(),
        arch: Architecture {
            hidden: vec![],
            bias: false,
        },
        episodes: args.episodes,
        dist: WeightDist::Normal { std: 1.0 },
        policy: rwg_core::policy::PolicyKind::Network,
        non_finite: Default::default(),
    };
    // Warm-up (untimed): starts the second worker process.
    bridge_run(&src, &plan, 64.min(args.samples), 2)?;
    let mut row = Row {
        env: id.to_string(),
        ..Row::default()
    };
    let kwargs = serde_json::Value::Object(cfg.kwargs.clone()).to_string();
    for rep in 0..args.repeats {
        let (steps, secs, cpu) = bridge_run(&src, &plan, args.samples, 1)?;
        row.steps_per_run = steps;
        row.bridge_1_worker.push(steps as f64 / secs);
        row.bridge_1_worker_cpu.push(steps as f64 / cpu);
        let c = python_json(
            Command::new(&cfg.python)
                .args(["-c", CEILING_PY, &gid, &kwargs, &steps.to_string()])
                .arg(rep.to_string()),
        )?;
        let n = c["steps"].as_f64().unwrap_or(0.0);
        row.ceiling
            .push(n / c["wall_s"].as_f64().unwrap_or(f64::NAN));
        row.ceiling_cpu
            .push(n / c["cpu_s"].as_f64().unwrap_or(f64::NAN));
        let (steps2, secs2, cpu2) = bridge_run(&src, &plan, args.samples, 2)?;
        row.bridge_2_workers.push(steps2 as f64 / secs2);
        row.bridge_2_workers_cpu.push(steps2 as f64 / cpu2);
        if let Some(peer) = &args.peer {
            let p = run_peer(args, peer, &cfg.python, &gid)?;
            row.peer.push(p["steps_per_s"].as_f64().unwrap_or(f64::NAN));
            row.peer_cpu
                .push(p["steps_per_cpu_s"].as_f64().unwrap_or(f64::NAN));
        }
    }
    Ok(row)
}

/// Runs the peer script on env `gid` with `python`: its JSON line.
fn run_peer(
    args: &GymBenchArgs,
    peer: &std::path::Path,
    python: &str,
    gid: &str,
) -> Result<serde_json::Value> {
    let out = std::env::temp_dir().join(format!("rwg-bench-peer-{}.csv", std::process::id()));
    // the peer runs in its own folder (it imports its neighbours): name
    // it, and a relative interpreter path, from here first
    let peer = std::fs::canonicalize(peer)
        .with_context(|| format!("cannot find the peer script {}", peer.display()))?;
    let python = if python.contains('/') {
        std::path::absolute(python).unwrap_or_else(|_| PathBuf::from(python))
    } else {
        PathBuf::from(python)
    };
    let mut cmd = Command::new(&python);
    cmd.arg(&peer).args([
        "--env",
        gid,
        "--samples",
        &(args.samples / 5).max(1).to_string(),
        "--episodes",
        &args.episodes.to_string(),
        "--out",
        out.to_str().unwrap_or("peer.csv"),
    ]);
    if let Some(dir) = peer.parent() {
        cmd.current_dir(dir);
    }
    let p = python_json(&mut cmd)?;
    let _ = std::fs::remove_file(&out);
    Ok(p)
}

/// Prints the table of one env's measurements.
fn print_env(args: &GymBenchArgs, row: &Row) {
    let m = |v: &[f64]| median(v);
    crate::outln!(
        "{}  ({} env steps per bridge run, {} repeats; median [min-max])",
        row.env,
        row.steps_per_run,
        args.repeats
    );
    let columns = TextColumns::new(
        &[
            (48, Align::Left),
            (26, Align::Right),
            (26, Align::Right),
            (0, Align::Left),
        ],
        " ",
    )
    .gap(2, "  ");
    crate::outln!(
        "  {}",
        columns.line(&["", "env steps/s (wall)", "env steps/CPU-s"])
    );
    let line = |what: &str, wall: &[f64], cpu: &[f64], note: String| {
        let cells = [what.to_string(), fmt_stat(wall), fmt_stat(cpu), note];
        crate::outln!("  {}", columns.line(&cells));
    };
    line(
        "pure-Python loop, pre-drawn actions (ceiling)",
        &row.ceiling,
        &row.ceiling_cpu,
        String::new(),
    );
    line(
        "bridge, 1 worker",
        &row.bridge_1_worker,
        &row.bridge_1_worker_cpu,
        format!(
            "{:.2}x ceiling per CPU-s",
            m(&row.bridge_1_worker_cpu) / m(&row.ceiling_cpu)
        ),
    );
    line(
        "bridge, 2 workers",
        &row.bridge_2_workers,
        &row.bridge_2_workers_cpu,
        format!(
            "{:.2}x 1 worker (wall)",
            m(&row.bridge_2_workers) / m(&row.bridge_1_worker)
        ),
    );
    if !row.peer.is_empty() {
        line(
            &format!("peer script ({} networks)", (args.samples / 5).max(1)),
            &row.peer,
            &row.peer_cpu,
            format!(
                "bridge 1 worker = {:.1}x per CPU-s",
                m(&row.bridge_1_worker_cpu) / m(&row.peer_cpu)
            ),
        );
    }
}
