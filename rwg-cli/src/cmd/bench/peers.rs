//! `rwg bench peers`: the whole `rwg run --threads 1` command against the
//! strongest peer, gymnax-raw (`gymnax_rwg.py --step raw`), measured side by
//! side in one invocation. With `--source gymnax` it makes two comparisons:
//! rwg's whole run against gymnax-raw's whole process on the paper's 10^4
//! networks, then against gymnax-raw's compiled run alone on 3 x 10^4.
//!
//! Both sides run as child processes, interleaved (round by round, workload
//! by workload, alternating which side goes first), pinned to one core, and
//! are compared by env steps per CPU-second:
//!
//! - rwg: the child's whole CPU time (user + system, from `getrusage` of the
//!   waited-for child): start-up, sampling, block commits, statistics and the
//!   report, everything `rwg run` does;
//! - gymnax-raw: the CPU time its JSON line reports for the compiled program's
//!   run (JAX start-up and XLA compilation excluded, as the peer reports them
//!   separately), or, in a whole-process comparison, the child's whole CPU
//!   time, as for rwg.
//!
//! Env steps on both sides are the transitions inside episodes (every step of
//! every episode, up to and including the terminal or truncating one).
//!
//! rwg runs at each SIMD level of `--simd` (the child's `RWG_SIMD`), once per
//! round and workload each, among the peer's run; every level must score the
//! workload identically (checked), so the levels differ in speed only.
//! With `--source gymnax`, rwg runs gymnax's envs as its `gymnax:` envs
//! instead ([`source`]): the child's CPU time then includes its JAX worker
//! process (a waited-for grandchild), JAX's start-up and the compilation,
//! each run with an empty compilation cache of its own (`RWG_JAX_CACHE`), so
//! every run compiles as gymnax-raw does.
//! [`report`] holds the measurements, their ratios and the table.

mod peer;
mod process;
mod report;
mod source;

use anyhow::{bail, Context, Result};
use peer::{measure_peer, peer_python, peers_dir};
use process::{measure, pin_to, TempDir};
use report::{cpu_model, load_avg, now_utc, print_table, Report, Row, Setup};
use rwg_env::simd::Simd;
use rwg_study::rundir::outputs::{Output, OutputKind};
use std::path::{Path, PathBuf};
use std::process::Command;

pub use source::{Part, PeerTime, Source, PEER_WORKLOADS};

/// The `pip install` line of the peer's virtualenv (versions that work with
/// `gymnax_rwg.py`; `six` because gymnax 1.0.1 imports it undeclared).
pub const PEER_PIP_PACKAGES: &str = "numpy==2.4.6 gymnasium==1.3.0 jax==0.10.2 jaxlib==0.10.2 \
                                     gymnax==1.0.1 flax==0.12.8 six==1.17.0";

/// Arguments of `rwg bench peers`.
#[derive(clap::Args)]
pub struct PeersArgs {
    /// Python interpreter with the peer's packages (jax, gymnax). Default:
    /// VENV/bin/python.
    #[arg(long, env = "RWG_PEER_PYTHON", value_name = "FILE")]
    python: Option<PathBuf>,
    /// Virtualenv of the peer, used when --python is not given.
    #[arg(long, value_name = "DIR", default_value = "target/peers-venv")]
    venv: PathBuf,
    /// Create --venv (python3 -m venv, then pip install of the peer's pinned
    /// packages) if it does not exist.
    #[arg(long)]
    create_venv: bool,
    /// Directory of the peer scripts (gymnax_rwg.py and rwg_common.py),
    /// relative to the current directory: the repository's `benches/peers`
    /// when run from its top folder.
    #[arg(
        long,
        env = "RWG_PEERS_DIR",
        value_name = "DIR",
        default_value = "benches/peers"
    )]
    peers: PathBuf,
    /// The rwg binary to measure (default: this one).
    #[arg(long, value_name = "FILE")]
    rwg: Option<PathBuf>,
    /// rwg's envs: `builtin` (float64, Gymnasium's numbers) or `gymnax`
    /// (gymnax's envs as rwg's `gymnax:` envs, run by the peer's Python).
    #[arg(long, value_enum, default_value_t = Source::Builtin)]
    source: Source,
    /// Networks per workload for `rwg run` (default: 3000; built-in envs
    /// only).
    #[arg(long, value_name = "N")]
    rwg_samples: Option<u64>,
    /// Networks per workload for gymnax-raw (default: 1000; built-in envs
    /// only).
    #[arg(long, value_name = "N")]
    peer_samples: Option<u64>,
    /// With --source gymnax: networks per workload (both sides) of the
    /// comparison of whole processes (default: 10000, the paper's N; 0
    /// leaves it out).
    #[arg(long, value_name = "N")]
    whole_samples: Option<u64>,
    /// With --source gymnax: networks per workload (both sides) of the
    /// comparison with gymnax-raw's compiled run alone (default: 30000; 0
    /// leaves it out).
    #[arg(long, value_name = "N")]
    compiled_samples: Option<u64>,
    /// Episodes per network (both sides).
    #[arg(long, value_name = "E", default_value_t = 20)]
    episodes: u32,
    /// Measurements of each side per workload (interleaved rounds).
    #[arg(long, value_name = "R", default_value_t = 5)]
    rounds: u32,
    /// Run only the workloads of this environment (repeatable).
    #[arg(long = "env", value_name = "ID")]
    envs: Vec<String>,
    /// Seed of both sides.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The core both sides are pinned to.
    #[arg(long, value_name = "CPU", default_value_t = 0)]
    cpu: usize,
    /// Do not pin (figures then depend on how the scheduler spreads threads).
    #[arg(long)]
    no_pin: bool,
    /// Directory for the run directories and the peer's CSVs (default: a
    /// fresh directory under the system's temporary directory, removed at the end).
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// rwg's SIMD levels to measure, comma-separated (scalar, avx2, avx512;
    /// e.g. avx2,avx512): rwg runs once per level in every round (its
    /// RWG_SIMD set to it), and the last level is compared with the first.
    /// Default: the level rwg runs (RWG_SIMD, else AVX2 where the CPU has it).
    #[arg(long, value_name = "LEVELS", value_delimiter = ',')]
    simd: Vec<String>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// The levels `--simd` names, in its order: each one this CPU has, none
/// twice (an error naming every level the CPU lacks); the level rwg runs if
/// none is named.
fn simd_levels(names: &[String]) -> Result<Vec<Simd>> {
    if names.is_empty() {
        return Ok(vec![rwg_env::simd::level()]);
    }
    let (mut levels, mut lacking) = (Vec::new(), Vec::new());
    for name in names {
        let name = name.trim();
        match (rwg_env::simd::parse(name), Simd::from_name(name)) {
            (Ok(level), _) if levels.contains(&level) => bail!("--simd lists {level} twice"),
            (Ok(level), _) => levels.push(level),
            (Err(_), Some(level)) => {
                if !lacking.contains(&level.name()) {
                    lacking.push(level.name());
                }
            }
            (Err(e), None) => bail!(
                "--simd: {name:?} is not a SIMD level: expected {}",
                e.expected
            ),
        }
    }
    if !lacking.is_empty() {
        let have: Vec<&str> = Simd::available_levels()
            .into_iter()
            .map(Simd::name)
            .collect();
        bail!(
            "--simd: this CPU has no {} (the levels it has: {})",
            lacking.join(", "),
            have.join(", ")
        );
    }
    Ok(levels)
}

/// Reads `env_steps` of a finished run directory's run.json.
fn run_env_steps(dir: &Path) -> Result<u64> {
    let p = dir.join(rwg_study::rundir::RUN_JSON);
    let text =
        std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", p.display()))?;
    v.get("env_steps")
        .and_then(|x| x.as_u64())
        .with_context(|| format!("{} has no env_steps", p.display()))
}

/// The bytes of the scores.csv of a finished one-cell run directory.
fn cell_scores(dir: &Path) -> Result<Vec<u8>> {
    let cells = dir.join(rwg_study::rundir::CELLS);
    let read = || -> std::io::Result<Vec<u8>> {
        let mut found = None;
        for entry in std::fs::read_dir(&cells)? {
            let path = entry?.path().join(rwg_study::rundir::SCORES_CSV);
            if found.replace(path).is_some() {
                return Err(std::io::Error::other("more than one cell"));
            }
        }
        let path = found.ok_or_else(|| std::io::Error::other("no cell"))?;
        std::fs::read(path)
    };
    read().with_context(|| format!("cannot read the scores of {}", cells.display()))
}

/// What every measurement of a sitting shares.
struct Sitting {
    source: Source,
    levels: Vec<Simd>,
    rwg: PathBuf,
    python: PathBuf,
    peers_dir: PathBuf,
    work: PathBuf,
}

/// The checks of the arguments that need no peer: counts, levels, envs.
/// Returns rwg's SIMD levels and the sitting's comparisons.
fn check_args(args: &PeersArgs) -> Result<(Vec<Simd>, Vec<Part>)> {
    match args.source {
        Source::Builtin if args.whole_samples.is_some() || args.compiled_samples.is_some() => {
            bail!("--whole-samples and --compiled-samples are for --source gymnax")
        }
        Source::Gymnax if args.rwg_samples.is_some() || args.peer_samples.is_some() => bail!(
            "--rwg-samples and --peer-samples are for the built-in envs: with --source gymnax \
             both sides run the same networks, --whole-samples and --compiled-samples"
        ),
        _ => {}
    }
    let parts = args.source.parts(
        (args.rwg_samples, args.peer_samples),
        (args.whole_samples, args.compiled_samples),
    );
    let zero = parts
        .iter()
        .any(|p| p.rwg_samples == 0 || p.peer_samples == 0);
    if parts.is_empty() || zero || args.episodes == 0 || args.rounds == 0 {
        bail!(
            "--rwg-samples, --peer-samples, --episodes and --rounds must be at least 1, and \
             --whole-samples and --compiled-samples cannot both be 0"
        );
    }
    if args.source == Source::Gymnax && !args.simd.is_empty() {
        bail!(
            "--simd is for the built-in envs: a gymnax: env computes in JAX, whatever \
             RWG_SIMD (leave --simd out with --source gymnax)"
        );
    }
    let levels = simd_levels(&args.simd)?;
    let workloads = args.source.workloads();
    for e in &args.envs {
        if !workloads.iter().any(|w| w.0 == e) {
            let mut names: Vec<&str> = workloads.iter().map(|w| w.0).collect();
            names.dedup();
            bail!(
                "no peer workload uses {e} (--source {}); its workloads: {}",
                source_name(args.source),
                names.join(", ")
            );
        }
    }
    Ok((levels, parts))
}

/// `builtin` or `gymnax`, as `--source` takes it.
fn source_name(source: Source) -> &'static str {
    match source {
        Source::Builtin => "builtin",
        Source::Gymnax => "gymnax",
    }
}

/// Runs `rwg run` of workload `name` at `level` once and adds it to `row`'s
/// measurements at index `k`.
fn measure_rwg(s: &Sitting, row: &mut Row, name: &str, k: usize) -> Result<()> {
    let level = s.levels[k];
    let manifest = s.work.join(format!("{name}.toml"));
    let run_dir = s.work.join(format!("{name}-{level}"));
    let mut cmd = Command::new(&s.rwg);
    cmd.arg("run")
        .arg(&manifest)
        .args(["--threads", "1", "--force-new", "--out"])
        .arg(&run_dir)
        .env(rwg_env::simd::VAR, level.name());
    let label = row.label();
    let what = match s.source {
        Source::Builtin => format!("RWG_SIMD={level} rwg run ({label})"),
        Source::Gymnax => format!("rwg run ({label}; its manifest: {})", manifest.display()),
    };
    // every gymnax: run compiles, as gymnax-raw does: an empty cache each
    let cache = s.work.join(format!("{name}-jax-cache"));
    if s.source == Source::Gymnax {
        let _ = std::fs::remove_dir_all(&cache);
        cmd.env(rwg_jax::CACHE_VAR, &cache);
    }
    let measured = measure(cmd, &what);
    let _ = std::fs::remove_dir_all(&cache);
    let (_, cpu, wall) = measured?;
    let steps = run_env_steps(&run_dir)?;
    row.rwg[k].measured.push(steps, cpu, wall);
    Ok(())
}

/// Every level of one built-in workload must have written the same scores.
fn check_levels_agree(s: &Sitting, name: &str, label: &str) -> Result<()> {
    let run_dir = |level: Simd| s.work.join(format!("{name}-{level}"));
    let first = cell_scores(&run_dir(s.levels[0]))?;
    for &level in &s.levels[1..] {
        if cell_scores(&run_dir(level))? != first {
            bail!(
                "{label}: rwg run at RWG_SIMD={level} wrote other scores than at \
                 RWG_SIMD={} (every level must give the same bits; --work-dir keeps \
                 the run directories)",
                s.levels[0]
            );
        }
    }
    Ok(())
}

/// One round of workload `i`: its manifest, then rwg at each level and the
/// peer, in an order that alternates from round to round and workload to
/// workload.
fn measure_round(s: &Sitting, args: &PeersArgs, row: &mut Row, i: usize, round: u32) -> Result<()> {
    let name = format!("w{i}");
    let manifest = s.work.join(format!("{name}.toml"));
    let peer_env = row
        .env
        .strip_prefix("gymnax:")
        .unwrap_or(&row.env)
        .to_string();
    let text = s.source.manifest_text(
        &peer_env,
        &row.hidden,
        row.rwg[0].measured.samples,
        args.episodes,
        args.seed,
        &s.python,
    );
    std::fs::write(&manifest, text)
        .with_context(|| format!("cannot write {}", manifest.display()))?;
    // rwg at each level in the listed order, then the peer; every other
    // time the reverse.
    let mut order: Vec<Option<usize>> = (0..s.levels.len()).map(Some).chain([None]).collect();
    if (round + i as u32) % 2 == 1 {
        order.reverse();
    }
    for side in order {
        match side {
            Some(k) => measure_rwg(s, row, &name, k)?,
            None => measure_peer(s, row, &name, args.episodes, args.seed)?,
        }
    }
    check_levels_agree(s, &name, &row.label())?;
    row.update_ratios();
    crate::errln!(
        "round {}/{}  {:<32}{}",
        round + 1,
        args.rounds,
        format!("{} ({})", row.label(), row.samples_label()),
        row.progress()
    );
    Ok(())
}

/// Runs `rwg bench peers`.
pub fn run(args: PeersArgs) -> Result<()> {
    let (levels, parts) = check_args(&args)?;
    // The folders it fills, checked against the run directories around them.
    let mut _locks = vec![];
    let folders = [
        args.work_dir.as_ref(),
        args.create_venv.then_some(&args.venv),
    ];
    for dir in folders.into_iter().flatten() {
        let output = Output::new(dir, OutputKind::Folder);
        _locks.extend(crate::cmd::claim_output(
            output,
            "a folder outside the run works now",
        )?);
    }
    let peers_dir = peers_dir(&args)?;
    let python = peer_python(&args)?;
    let rwg = match &args.rwg {
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot find this rwg binary")?,
    };
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    if !args.no_pin {
        pin_to(args.cpu)?;
    }
    let (work, _cleanup) = match &args.work_dir {
        Some(d) => (d.clone(), TempDir(None)),
        None => {
            let d = std::env::temp_dir().join(format!("rwg-bench-peers-{}", std::process::id()));
            (d.clone(), TempDir(Some(d)))
        }
    };
    std::fs::create_dir_all(&work).with_context(|| format!("cannot create {}", work.display()))?;
    let sitting = Sitting {
        source: args.source,
        levels,
        rwg,
        python,
        peers_dir,
        work,
    };
    let s = &sitting;
    let workloads: Vec<_> = s
        .source
        .workloads()
        .iter()
        .filter(|w| args.envs.is_empty() || args.envs.iter().any(|e| e == w.0))
        .collect();
    let mut rows: Vec<Row> = parts
        .iter()
        .flat_map(|&part| {
            workloads.iter().map(move |&&(env, hidden)| {
                Row::new(
                    &s.source.rwg_env(env),
                    hidden,
                    args.episodes,
                    &s.levels,
                    part,
                )
            })
        })
        .collect();
    let setup_start = (now_utc(), load_avg());
    for round in 0..args.rounds {
        for (i, row) in rows.iter_mut().enumerate() {
            measure_round(s, &args, row, i, round)?;
        }
    }
    let report = Report {
        setup: setup(s, &args, setup_start, cpus),
        rows,
    };
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

/// The report's account of the sitting.
fn setup(s: &Sitting, args: &PeersArgs, start: (String, String), cpus: usize) -> Setup {
    let rwg_command = match s.source {
        Source::Builtin => format!(
            "rwg run <one-cell manifest> --threads 1 --force-new --out <dir>  (the row's \
             networks x {} episodes, no bias, report included)",
            args.episodes
        ),
        Source::Gymnax => format!(
            "rwg run <one-cell manifest of gymnax:<env>, python = the peer's> --threads 1 \
             --force-new --out <dir>  (the row's networks x {} episodes, no bias, float32, an \
             empty RWG_JAX_CACHE: JAX start-up, compilation and report included)",
            args.episodes
        ),
    };
    Setup {
        date_utc: start.0,
        cpu_model: cpu_model(),
        cpus,
        pinned_cpu: (!args.no_pin).then_some(args.cpu),
        load_avg_start: start.1,
        load_avg_end: load_avg(),
        rounds: args.rounds,
        seed: args.seed,
        source: s.source,
        simd_levels: s.levels.iter().map(|l| l.name()).collect(),
        rwg_binary: s.rwg.display().to_string(),
        rwg_command,
        peer_command: format!(
            "python gymnax_rwg.py --step raw --env <env> --hidden <h> --no-bias --samples <the \
             row's networks> --episodes {} --seed {} --out <csv>",
            args.episodes, args.seed
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simd_levels_are_the_listed_ones_the_cpu_has() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(simd_levels(&[]).unwrap(), [rwg_env::simd::level()]);
        let have = Simd::available_levels();
        let listed: Vec<&str> = have.iter().rev().map(|l| l.name()).collect();
        let got = simd_levels(&names(&listed)).unwrap();
        assert_eq!(got, have.iter().rev().copied().collect::<Vec<_>>());
        assert_eq!(simd_levels(&names(&[" scalar"])).unwrap(), [Simd::Scalar]);
        let e = simd_levels(&names(&["scalar", "sse4"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"sse4\" is not a SIMD level"), "{e}");
        assert!(e.contains("scalar, avx2, avx512"), "{e}");
        let e = simd_levels(&names(&["scalar", "scalar"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lists scalar twice"), "{e}");
        let lacking: Vec<&str> = Simd::ALL
            .into_iter()
            .filter(|l| !l.available())
            .map(Simd::name)
            .collect();
        if !lacking.is_empty() {
            let mut listed = names(&lacking);
            listed.insert(0, "scalar".into());
            let e = simd_levels(&listed).unwrap_err().to_string();
            assert!(e.contains(&format!("has no {}", lacking.join(", "))), "{e}");
        }
    }
}
