//! Error messages a user meets first (issue 15): each OS error said once, with the
//! path and a "did you mean" for a nearby file; commands that need a run
//! directory say "not a run directory" and what one holds.

mod common;
use common::*;

#[test]
fn a_missing_manifest_is_named_once_with_a_hint() {
    let dir = temp_dir("msg-manifest");
    std::fs::write(dir.join("quick.toml"), "samples = 1\n").unwrap();
    let typo = dir.join("qick.toml");
    let err = rwg_err(&["run", typo.to_str().unwrap()]);
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    assert!(
        err.contains(&format!("cannot read manifest {}", typo.display())),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "hint: {} does not exist; did you mean {}?",
            typo.display(),
            dir.join("quick.toml").display()
        )),
        "{err}"
    );
    // no hint when nothing is near
    let err = rwg_err(&["run", dir.join("zzzzzzzzzz.toml").to_str().unwrap()]);
    assert!(!err.contains("did you mean"), "{err}");
    // nor for an output path that does not exist yet: it is no typo, even
    // beside a folder of a similar name
    std::fs::create_dir_all(dir.join("runs/quick")).unwrap();
    let out = dir.join("runs/quik");
    let err = rwg_err(&[
        "run",
        typo.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(err.matches("did you mean").count(), 1, "{err}");
    assert!(
        !err.contains(&format!("{} does not exist", out.display())),
        "{err}"
    );
}

#[test]
fn commands_that_need_a_run_directory_say_so() {
    let dir = temp_dir("msg-rundir");
    let run = synthetic_run("msg-rundir-run", 20, 2);
    let parent = run.parent().unwrap();
    let name = run.file_name().unwrap().to_str().unwrap();
    let merged = dir.join("merged");
    for cmd in [
        vec!["stats", dir.to_str().unwrap()],
        vec!["verify", dir.to_str().unwrap()],
        vec!["plot", dir.to_str().unwrap()],
        vec![
            "merge",
            dir.to_str().unwrap(),
            "--out",
            merged.to_str().unwrap(),
        ],
        vec!["report", dir.to_str().unwrap()],
        vec!["top", dir.to_str().unwrap()],
        vec!["compare", dir.to_str().unwrap()],
        vec![
            "replay",
            dir.to_str().unwrap(),
            "--env",
            "CartPole-v0",
            "--arch",
            "0HL",
            "--bias",
            "false",
            "--sample",
            "0",
        ],
    ] {
        let err = rwg_err(&cmd);
        assert!(
            err.contains(&format!(
                "{} is not a run directory (it has no run.json)",
                dir.display()
            )) && err.contains("run.json, manifest.toml and cells/"),
            "{cmd:?}: {err}"
        );
        assert!(!err.contains("os error"), "{cmd:?}: {err}");
    }
    // a cell directory, or a file, of a run: the run is named
    let cell = std::fs::read_dir(run.join("cells"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    for inside in [cell, run.join("run.json"), run.join("manifest.toml")] {
        for cmd in ["stats", "top", "verify", "status"] {
            let err = rwg_err(&[cmd, inside.to_str().unwrap()]);
            assert!(
                err.contains(&format!(
                    "; it is inside the run directory {}: give that",
                    run.display()
                )),
                "{cmd} {}: {err}",
                inside.display()
            );
        }
    }
    // a manifest given where a run directory is expected
    let m = dir.join("m.toml");
    std::fs::write(&m, "samples = 2\n").unwrap();
    for cmd in ["stats", "status"] {
        let err = rwg_err(&[cmd, m.to_str().unwrap()]);
        assert!(
            err.contains("(it is a file)") && err.contains("`rwg run "),
            "{cmd}: {err}"
        );
    }
    // a typo of an existing run directory
    let typo = parent.join(format!("{name}x"));
    let err = rwg_err(&["stats", typo.to_str().unwrap()]);
    assert!(err.contains("(it does not exist)"), "{err}");
    assert!(
        err.contains(&format!("did you mean {}?", run.display())),
        "{err}"
    );
}

#[test]
fn a_negative_count_is_refused_without_a_tip_that_fails() {
    let err = rwg_err(&["run", "examples/quick.toml", "--samples", "-5"]);
    assert!(err.contains("invalid value '-5' for '--samples"), "{err}");
    assert!(!err.contains("-- -5"), "{err}");
}
