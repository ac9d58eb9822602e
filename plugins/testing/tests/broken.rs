//! The deliberately broken Rust plugin (`librwg_testing_plugins.so`): every
//! fault becomes a clear error, never an abort (except the segfault, which
//! is checked in a child process).

mod common;

use std::path::PathBuf;

use rwg_env::{Action, Environment};
use rwg_plugin_host::{check_plugin_env, load_plugin, CheckStatus, Plugin};
use rwg_testing_plugins::Fault;

fn lib() -> PathBuf {
    common::rust_plugin("rwg_testing_plugins", "rwg-testing-plugins")
}

fn plugin() -> Plugin {
    load_plugin(lib()).unwrap()
}

/// Steps `fault`'s env with action 1 until it fails; returns the error text.
fn first_error(fault: Fault) -> (usize, String, bool) {
    let p = plugin();
    let mut env = p.env(fault.id()).unwrap().create("").unwrap();
    let mut obs = [0.0];
    env.reset(0, &mut obs).unwrap();
    for t in 1..=10 {
        if let Err(e) = env.step(Action::Discrete(1), &mut obs) {
            return (t, e.to_string(), env.is_poisoned());
        }
    }
    panic!("{} did not fail", fault.id());
}

#[test]
fn panic_in_step_is_an_error_and_poisons_the_instance() {
    let (t, msg, poisoned) = first_error(Fault::PanicInStep);
    assert_eq!(t, 3);
    assert!(poisoned);
    assert_eq!(
        msg,
        "plugin 'broken' env 'broken/PanicInStep-v0': step failed with RWG_ERR_PANIC (5): \
         panic: broken/PanicInStep-v0 panics on step 3"
    );
}

#[test]
fn nan_observation_is_an_error() {
    let (t, msg, poisoned) = first_error(Fault::NanObservation);
    assert_eq!(t, 2);
    assert!(!poisoned);
    assert_eq!(
        msg,
        "plugin 'broken' env 'broken/NaNObservation-v0': step returned a non-finite \
         observation: obs[0] = NaN"
    );
}

#[test]
fn nan_reward_is_an_error() {
    let (t, msg, _) = first_error(Fault::NanReward);
    assert_eq!(t, 2);
    assert_eq!(
        msg,
        "plugin 'broken' env 'broken/NaNReward-v0': step returned a non-finite reward: NaN"
    );
}

#[test]
fn the_checker_fails_each_broken_env_without_dying() {
    let p = plugin();
    let failed = |fault: Fault| -> Vec<String> {
        check_plugin_env(p.env(fault.id()).unwrap(), "")
            .into_iter()
            .filter(|r| r.status == CheckStatus::Failed)
            .map(|r| r.name)
            .collect()
    };
    for fault in [Fault::PanicInStep, Fault::NanObservation, Fault::NanReward] {
        let f = failed(fault);
        assert!(f.contains(&"rollout".to_string()), "{}: {f:?}", fault.id());
    }
    let f = failed(Fault::HiddenGlobalState);
    assert!(f.contains(&"independent instances".to_string()), "{f:?}");
}

/// Run as a child by `segfault_in_step_kills_only_a_child_process`.
#[test]
fn segfault_child() {
    if std::env::var_os("RWG_TEST_SEGFAULT_CHILD").is_none() {
        return;
    }
    let p = plugin();
    let mut env = p
        .env(Fault::SegfaultInStep.id())
        .unwrap()
        .create("")
        .unwrap();
    let mut obs = [0.0];
    env.reset(0, &mut obs).unwrap();
    let _ = env.step(Action::Discrete(1), &mut obs);
    unreachable!("the step should have crashed the process");
}

#[cfg(unix)]
#[test]
fn segfault_in_step_kills_only_a_child_process() {
    use std::os::unix::process::ExitStatusExt;
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "segfault_child",
            "--test-threads=1",
            "--nocapture",
        ])
        .env("RWG_TEST_SEGFAULT_CHILD", "1")
        .output()
        .unwrap();
    assert_eq!(
        out.status.signal(),
        Some(11),
        "expected SIGSEGV, got {:?}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}
