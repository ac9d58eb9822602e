//! The peer's side of `rwg bench peers`: its Python (a virtualenv
//! created if asked), its scripts' directory, one run of gymnax-raw and
//! what its JSON line says.

use super::process::measure;
use super::report::Row;
use super::{PeerTime, PeersArgs, Sitting, PEER_PIP_PACKAGES};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the peer's last stdout line (JSON) says.
#[derive(Debug, PartialEq)]
struct PeerRun {
    env_steps: u64,
    cpu_s: f64,
    wall_s: f64,
    compile_s: f64,
}

/// Parses the peer's stdout: its last non-empty line is its JSON result.
fn parse_peer_output(stdout: &str) -> Result<PeerRun> {
    let line = stdout
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .context("the peer printed nothing on stdout")?;
    let v: serde_json::Value = serde_json::from_str(line)
        .with_context(|| format!("the peer's last line is not JSON: {line}"))?;
    let num = |k: &str| {
        v.get(k)
            .and_then(|x| x.as_f64())
            .with_context(|| format!("the peer's JSON lacks the number `{k}`: {line}"))
    };
    let run = PeerRun {
        env_steps: num("env_steps")? as u64,
        cpu_s: num("cpu_s")?,
        wall_s: num("wall_s")?,
        compile_s: num("compile_s")?,
    };
    if run.cpu_s <= 0.0 || run.env_steps == 0 {
        bail!("the peer reports no work ({line}); use more samples");
    }
    Ok(run)
}

/// The peer's Python: --python, else the venv's (created if asked).
pub(super) fn peer_python(args: &PeersArgs) -> Result<PathBuf> {
    // The peer runs in the scripts' directory, so a relative interpreter
    // path would be looked up there: make it absolute first (not canonical,
    // which would follow the venv's symlink out of the venv).
    let absolute = |p: &Path| {
        std::path::absolute(p).with_context(|| format!("cannot resolve {}", p.display()))
    };
    if let Some(p) = &args.python {
        if !p.exists() {
            bail!("--python / RWG_PEER_PYTHON {} does not exist", p.display());
        }
        return absolute(p);
    }
    let py = args.venv.join("bin").join("python");
    if py.exists() {
        return absolute(&py);
    }
    if !args.create_venv {
        bail!(
            "no peer virtualenv at {} (and no --python / RWG_PEER_PYTHON): create one with\n  \
             python3 -m venv {v} && {v}/bin/pip install {PEER_PIP_PACKAGES}\n\
             or pass --create-venv",
            args.venv.display(),
            v = args.venv.display()
        );
    }
    crate::errln!("creating the peer virtualenv {}", args.venv.display());
    let st = Command::new("python3")
        .args(["-m", "venv"])
        .arg(&args.venv)
        .status()
        .context("cannot run python3 -m venv")?;
    if !st.success() {
        bail!("python3 -m venv {} failed", args.venv.display());
    }
    let st = Command::new(args.venv.join("bin").join("pip"))
        .args(["install", "--disable-pip-version-check", "-q"])
        .args(PEER_PIP_PACKAGES.split_whitespace())
        .status()
        .context("cannot run pip")?;
    if !st.success() {
        bail!(
            "pip install {PEER_PIP_PACKAGES} failed in {}",
            args.venv.display()
        );
    }
    absolute(&py)
}

/// The peer script's directory, made absolute (the peer runs there, so a
/// relative --peers would be resolved twice).
pub(super) fn peers_dir(args: &PeersArgs) -> Result<PathBuf> {
    let script = args.peers.join("gymnax_rwg.py");
    if !script.exists() {
        bail!(
            "{} not found: run from the top folder of rwg's repository (the peer scripts are in \
             its benches/peers), or point --peers (or RWG_PEERS_DIR) to their directory",
            script.display()
        );
    }
    std::fs::canonicalize(&args.peers)
        .with_context(|| format!("cannot resolve --peers {}", args.peers.display()))
}

/// Runs gymnax-raw on `row`'s workload once and adds it to its measurements:
/// its compiled run's CPU time (as its JSON line reports it), or its whole
/// process's, as the row says.
pub(super) fn measure_peer(
    s: &Sitting,
    row: &mut Row,
    name: &str,
    episodes: u32,
    seed: u64,
) -> Result<()> {
    let label = row.label();
    let env = row
        .env
        .strip_prefix("gymnax:")
        .unwrap_or(&row.env)
        .to_string();
    let hidden: Vec<String> = row.hidden.iter().map(|h| h.to_string()).collect();
    let mut cmd = Command::new(&s.python);
    cmd.arg(s.peers_dir.join("gymnax_rwg.py"))
        .args([
            "--step",
            "raw",
            "--env",
            &env,
            "--hidden",
            &hidden.join(","),
        ])
        .args([
            "--no-bias",
            "--samples",
            &row.gymnax_raw.samples.to_string(),
        ])
        .args([
            "--episodes",
            &episodes.to_string(),
            "--seed",
            &seed.to_string(),
        ])
        .arg("--out")
        .arg(s.work.join(format!("{name}-gymnax.csv")))
        .current_dir(&s.peers_dir);
    let (stdout, cpu, wall) = measure(cmd, &format!("gymnax-raw ({label})"))?;
    let p = parse_peer_output(&stdout).with_context(|| format!("gymnax-raw ({label})"))?;
    match row.peer_time {
        PeerTime::Compiled => row.gymnax_raw.push(p.env_steps, p.cpu_s, p.wall_s),
        PeerTime::Whole => row.gymnax_raw.push(p.env_steps, cpu, wall),
    }
    row.gymnax_compile_s.push(p.compile_s);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A real line of `gymnax_rwg.py --step raw` (shortened), after a warning.
    const PEER_STDOUT: &str = "some warning\n{\"peer\": \"gymnax-raw\", \"env\": \"CartPole-v0\", \
        \"hidden\": \"\", \"bias\": false, \"samples\": 1000, \"episodes\": 20, \"wall_s\": 0.1305, \
        \"env_steps\": 884661, \"steps_per_s\": 6778934.9, \"cpu_s\": 0.1307, \
        \"steps_per_cpu_s\": 6768638.1, \"compile_s\": 1.214, \"setup_s\": 2.01}\n\n";

    #[test]
    fn parses_the_peers_last_json_line() {
        let p = parse_peer_output(PEER_STDOUT).unwrap();
        assert_eq!(
            p,
            PeerRun {
                env_steps: 884_661,
                cpu_s: 0.1307,
                wall_s: 0.1305,
                compile_s: 1.214
            }
        );
        let e = parse_peer_output("{\"env_steps\": 10}").unwrap_err();
        assert!(format!("{e:#}").contains("`cpu_s`"), "{e:#}");
        assert!(parse_peer_output("Traceback ...").is_err());
        assert!(parse_peer_output("").is_err());
    }
}
