//! Loads the built plugin library through the ABI, like rwg does.
//! (`cargo test -p rwg-example-plugin` builds the cdylib first; it lands in
//! the target dir's `<profile>/deps/` or `<profile>/`.)

use std::path::PathBuf;

use rwg_env::{Action, Environment};
use rwg_plugin_host::{check_plugin, library_file_name, load_plugin, CheckStatus};

fn plugin_path() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let file = library_file_name("rwg_example_plugin");
    [deps.parent().unwrap(), deps]
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{file} not found: run `cargo build -p rwg-example-plugin`"))
}

#[test]
fn loads_and_passes_the_checker() {
    let results = check_plugin(&plugin_path());
    let failed: Vec<String> = results
        .iter()
        .filter(|r| r.status == CheckStatus::Failed)
        .map(|r| r.to_string())
        .collect();
    assert!(failed.is_empty(), "{failed:#?}");
    assert!(results.len() > 20);
}

#[test]
fn a_simple_controller_reaches_the_target() {
    let p = load_plugin(plugin_path()).unwrap();
    assert_eq!(p.id(), "example");
    let ty = p.env("example/PointMass-v0").unwrap();
    let mut env = ty.make("radius=0.1", None).unwrap();
    let mut obs = [0.0; 6];
    let mut reached = 0;
    for seed in 0..10 {
        env.reset(seed, &mut obs).unwrap();
        loop {
            // PD control toward the target.
            let a = [
                4.0 * (obs[4] - obs[0]) - 2.0 * obs[2],
                4.0 * (obs[5] - obs[1]) - 2.0 * obs[3],
            ];
            let s = env.step(Action::Continuous(&a), &mut obs).unwrap();
            if s.terminated {
                reached += 1;
            }
            if s.terminated || s.truncated {
                break;
            }
        }
    }
    assert!(
        reached >= 8,
        "reached the target in {reached} of 10 episodes"
    );
}
