//! `rwg run` progress without a terminal: plain lines on stderr (what a pipe,
//! `nohup` or a Slurm log gets), and `--quiet` silences them.

mod common;
use common::*;

const STUDY: &str = r#"
samples = 160
episodes = 2
threads = 1
[[architectures]]
name = "0HL"
hidden = []
[[envs]]
id = "CartPole-v0"
[[envs]]
id = "Acrobot-v1"
max_episode_steps = 50
"#;

fn run(name: &str, extra: &[&str]) -> String {
    let dir = temp_dir(name);
    let m = dir.join("m.toml");
    std::fs::write(&m, STUDY).unwrap();
    let out = dir.join("run");
    let mut args = vec![
        "run",
        m.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-report",
    ];
    args.extend(extra);
    // stderr is a pipe here, as in a batch job's log
    let o = rwg_env(
        &args,
        &[("RWG_PROGRESS_INTERVAL", std::ffi::OsStr::new("0"))],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stderr).unwrap()
}

#[test]
fn plain_progress_lines_without_a_terminal() {
    let err = run("progress-lines", &[]);
    let lines: Vec<&str> = err.lines().collect();
    assert!(
        lines[0].starts_with("[0:00:00] 320 networks to compute"),
        "{err}"
    );
    // one line per block of 32 networks at interval 0, then the final one
    let progress: Vec<&&str> = lines
        .iter()
        .filter(|l| l.contains(" networks/s, "))
        .collect();
    assert_eq!(progress.len(), 320 / 32 + 1, "{err}");
    assert!(
        progress[0]
            .contains("cell 1/2 (0 done): CartPole-v0__0HL__nobias: 32/320 networks (10.0%)"),
        "{err}"
    );
    assert!(progress
        .iter()
        .any(|l| l.contains("cell 2/2 (1 done): Acrobot-v1__0HL__nobias")));
    for l in &progress {
        assert!(l.starts_with('[') && l.contains("env steps/s, ETA "), "{l}");
        assert!(
            !l.contains('\r') && !l.contains('\x1b'),
            "no terminal control: {l:?}"
        );
    }
    assert!(
        progress
            .last()
            .unwrap()
            .contains("] done: 320/320 networks (100.0%)"),
        "{err}"
    );
}

#[test]
fn quiet_silences_progress() {
    let err = run("progress-quiet", &["--quiet"]);
    assert!(
        !err.contains("networks/s") && !err.contains("to compute"),
        "{err}"
    );
}
