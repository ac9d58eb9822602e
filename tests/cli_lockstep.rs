//! The built-in envs' lockstep versions in `rwg run` (issue 13): a study
//! gives the same `scores.csv` and `samples.csv` bytes through the lockstep
//! envs (`RWG_LOCKSTEP=1`: all of them) and through one scalar env per lane
//! (`RWG_LOCKSTEP=0`): the paper's study (examples/paper.toml, small, both
//! bias settings) and the envs and options it does not cover.

mod common;
use common::*;
use std::path::{Path, PathBuf};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Runs the study into `out` with `RWG_LOCKSTEP` set to `lockstep`.
fn run(manifest: &Path, out: &Path, lockstep: &str, threads: &str) {
    let res = rwg_env(
        &[
            "run",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-report",
            "--threads",
            threads,
        ],
        &[("RWG_LOCKSTEP", lockstep.as_ref())],
    );
    assert!(res.status.success(), "{}", text(&res.stderr));
}

/// Every cell's scores.csv and samples.csv, by cell directory name.
fn results(out: &Path) -> Vec<(String, Vec<u8>, Vec<u8>)> {
    let mut cells: Vec<PathBuf> = std::fs::read_dir(out.join("cells"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cells.sort();
    cells
        .iter()
        .map(|c| {
            (
                c.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(c.join("scores.csv")).unwrap(),
                std::fs::read(c.join("samples.csv")).unwrap(),
            )
        })
        .collect()
}

fn assert_same(dir: &Path, manifest: &Path, cells: usize) {
    run(manifest, &dir.join("lockstep"), "1", "2");
    run(manifest, &dir.join("scalar"), "0", "1");
    let (a, b) = (results(&dir.join("lockstep")), results(&dir.join("scalar")));
    assert_eq!(a.len(), cells);
    assert_eq!(b.len(), cells);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(x.1 == y.1, "{}: scores.csv differs", x.0);
        assert!(x.2 == y.2, "{}: samples.csv differs", x.0);
    }
}

#[test]
fn the_paper_study_is_identical_with_and_without_lockstep() {
    let dir = temp_dir("lockstep-paper");
    let paper = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/paper.toml"),
    )
    .unwrap();
    assert!(paper.contains("samples = 10000\n") && paper.contains("episodes = 20\n"));
    let small = paper
        .replace("samples = 10000\n", "samples = 40\n")
        .replace("episodes = 20\n", "episodes = 3\n");
    let m = dir.join("paper.toml");
    std::fs::write(&m, small).unwrap();
    // 5 envs x 3 architectures x 2 bias settings.
    assert_same(&dir, &m, 30);
}

#[test]
fn other_envs_and_options_are_identical_with_and_without_lockstep() {
    let head = "seed = 11\nsamples = 40\nepisodes = 3\nbias = [true]\n\
                [[architectures]]\nname = \"0HL\"\nhidden = []\n\
                [[architectures]]\nname = \"1HL-4\"\nhidden = [4]\n";
    let studies = [
        "[[envs]]\nid = \"CartPole-v1\"\n\
         [[envs]]\nid = \"Pendulum-v1\"\n\
         [[envs]]\nid = \"MountainCarContinuous-v0\"\naction_dtype = \"float32\"\n\
         [[envs]]\nid = \"Acrobot-v1\"\nmax_episode_steps = 37\n",
        "[[envs]]\nid = \"Pendulum-v1\"\naction_dtype = \"float32\"\n\
         [[envs]]\nid = \"MountainCar-v0\"\nmax_episode_steps = 50\n",
    ];
    for (k, envs) in studies.iter().enumerate() {
        let dir = temp_dir(&format!("lockstep-options-{k}"));
        let m = dir.join("m.toml");
        std::fs::write(&m, format!("{head}{envs}")).unwrap();
        assert_same(&dir, &m, 2 * envs.matches("[[envs]]").count());
    }
}
