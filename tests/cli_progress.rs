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

/// A block that takes longer than the interval (a slow env, a long episode)
/// does not silence the log: the line comes on time, with the counts so far.
#[test]
fn lines_keep_coming_while_a_long_block_runs() {
    let dir = temp_dir("progress-slow");
    let m = dir.join("m.toml");
    // One block of 32 networks x 400 episodes of up to 999 steps: a second
    // or more in any build, with lines due every 0.1 s.
    std::fs::write(
        &m,
        "samples = 32\nepisodes = 400\nthreads = 1\n[[architectures]]\nname = \"0HL\"\n\
         hidden = []\n[[envs]]\nid = \"MountainCarContinuous-v0\"\n",
    )
    .unwrap();
    let out = dir.join("run");
    let t0 = std::time::Instant::now();
    let o = rwg_env(
        &[
            "run",
            m.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-report",
        ],
        &[("RWG_PROGRESS_INTERVAL", std::ffi::OsStr::new("0.1"))],
    );
    let secs = t0.elapsed().as_secs_f64();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(o.status.success(), "{err}");
    let waiting = err
        .lines()
        .filter(|l| l.contains(": 0/32 networks (0.0%)"))
        .count();
    assert!(waiting >= 2, "{secs:.2} s, yet:\n{err}");
    assert!(err.contains("] done: 32/32 networks (100.0%)"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
