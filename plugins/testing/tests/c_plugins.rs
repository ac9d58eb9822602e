//! C plugins: the example in `examples/plugin-c` and the broken handshakes
//! of `plugins/testing/c/handshake.c`, compiled with the system C compiler.

mod common;

use common::{c_out_dir, compile_c};
use rwg_env::{Action, EnvError, Environment, Space};
use rwg_plugin_host::{
    check_plugin, find_plugin_files, load_plugin, load_plugin_path, load_plugin_path_reserving,
    CheckStatus, PluginLoadErrorKind,
};

const CHAIN: &str = "examples/plugin-c/chain.c";
const HANDSHAKE: &str = "plugins/testing/c/handshake.c";

#[test]
fn c_example_loads_and_runs() {
    let dir = c_out_dir("example");
    let lib = compile_c(CHAIN, &dir, "chain", &[]);
    let p = load_plugin(&lib).unwrap();
    assert_eq!(p.id(), "c_example");
    assert_eq!(p.info().version, "1.0.0");
    let ty = p.env("c_example/Chain-v0").unwrap();
    assert_eq!(ty.spec().action_space, Space::Discrete { n: 2 });
    assert_eq!(ty.spec().max_episode_steps, Some(100));
    assert_eq!(ty.spec().reward_threshold, Some(0.8));

    // Always going right reaches the end of a 10-cell chain.
    let mut env = ty.make("", None).unwrap();
    let mut obs = [0.0; 2];
    env.reset(3, &mut obs).unwrap();
    assert_eq!(obs, [0.0, 0.0]);
    let mut ret = 0.0;
    let mut steps = 0;
    loop {
        let s = env.step(Action::Discrete(1), &mut obs).unwrap();
        ret += s.reward;
        steps += 1;
        if s.terminated || s.truncated {
            assert!(s.terminated, "reached the end");
            break;
        }
    }
    assert_eq!(obs[0], 1.0);
    assert!(steps >= 9 && ret > 0.5, "{steps} steps, return {ret}");

    // Config is parsed by the plugin; errors come back with its message.
    let mut short = ty.make("length=2", None).unwrap();
    short.reset(0, &mut obs).unwrap();
    let msg = ty.create("length=1").unwrap_err().to_string();
    assert!(
        msg.contains("length must be an integer in 2..1000"),
        "{msg}"
    );

    // Invalid actions are refused, not crashes.
    let mut raw = ty.create("").unwrap();
    assert_eq!(
        raw.step(Action::Discrete(0), &mut obs),
        Err(EnvError::ResetNeeded)
    );
    raw.reset(0, &mut obs).unwrap();
    let e = raw.step(Action::Discrete(2), &mut obs).unwrap_err();
    assert!(
        e.to_string().contains("must be 0 (left) or 1 (right)"),
        "{e}"
    );
}

#[test]
fn c_example_passes_the_checker() {
    let dir = c_out_dir("example-check");
    let lib = compile_c(CHAIN, &dir, "chain", &[]);
    let results = check_plugin(&lib);
    let bad: Vec<String> = results
        .iter()
        .filter(|r| r.status != CheckStatus::Passed)
        .map(|r| r.to_string())
        .collect();
    assert!(bad.is_empty(), "{bad:#?}");
}

fn handshake(define: &str) -> PluginLoadErrorKind {
    let dir = c_out_dir(&format!("handshake-{define}"));
    let lib = compile_c(HANDSHAKE, &dir, "handshake", &[define]);
    let e = load_plugin(&lib).unwrap_err();
    assert_eq!(e.path, lib);
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("plugin {}: ", lib.display())),
        "{text}"
    );
    e.kind
}

#[test]
fn the_unbroken_handshake_plugin_loads() {
    let dir = c_out_dir("handshake-ok");
    let lib = compile_c(HANDSHAKE, &dir, "handshake", &[]);
    let p = load_plugin(&lib).unwrap();
    assert_eq!(p.envs()[0].id(), "handshake/Ok-v0");
    assert_eq!(p.envs()[0].spec().reward_threshold, None);
}

#[test]
fn wrong_abi_version_is_refused_with_both_versions() {
    let k = handshake("BROKEN_WRONG_MAJOR");
    assert_eq!(
        k.to_string(),
        "ABI version mismatch: the plugin was built for ABI 2.2, this rwg speaks ABI 1.2 \
         (majors must match)"
    );
}

#[test]
fn broken_handshakes_give_clear_errors() {
    assert_eq!(
        handshake("BROKEN_NO_ENTRY"),
        PluginLoadErrorKind::NoEntrySymbol
    );
    assert!(matches!(
        handshake("BROKEN_NULL_ENTRY"),
        PluginLoadErrorKind::Declined { .. }
    ));
    assert_eq!(
        handshake("BROKEN_SMALL_ENTRY").to_string(),
        format!(
            "rwg_plugin_entry_t is too small: struct_size is 24, ABI 1.0 needs at least {} bytes",
            std::mem::size_of::<rwg_env::plugin::abi::RwgPluginEntry>()
        )
    );
    assert_eq!(
        handshake("BROKEN_BAD_TAG"),
        PluginLoadErrorKind::AbiTag {
            found: "some-other-plugin-system".into()
        }
    );
    assert_eq!(
        handshake("BROKEN_INIT_FAILS").to_string(),
        "init failed with RWG_ERR_INTERNAL (6): the simulator licence has expired"
    );
    assert_eq!(
        handshake("BROKEN_NO_ENVS"),
        PluginLoadErrorKind::EnvCount(0)
    );
}

#[test]
fn broken_descriptors_give_clear_errors() {
    let text = |d| handshake(d).to_string();
    assert_eq!(text("BROKEN_EMPTY_ID"), "environment #0: the id is empty");
    let t = text("BROKEN_BAD_UTF8_ID");
    assert!(t.starts_with("environment #0: id: not valid UTF-8"), "{t}");
    assert_eq!(
        text("BROKEN_DUP_IDS"),
        "duplicate environment id 'handshake/Ok-v0' (environments #0 and #1)"
    );
    assert_eq!(
        text("BROKEN_LOW_GT_HIGH"),
        "environment #0 'handshake/Ok-v0': observation space: Box low[0] = 1 > high[0] = 0"
    );
    assert_eq!(
        text("BROKEN_NULL_STEP"),
        "environment #0 'handshake/Ok-v0': env_vtable: step is NULL"
    );
    assert_eq!(
        text("BROKEN_HALF_BATCH"),
        "environment #0 'handshake/Ok-v0': env_vtable: step_many is set but reset_many is NULL (ABI 1.1 needs both or neither)"
    );
    assert_eq!(
        text("BROKEN_PARTIAL_VEC"),
        "environment #0 'handshake/Ok-v0': env_vtable: vec_destroy set but vec_create, vec_reset, vec_step, vec_last_error NULL (ABI 1.2 needs all five vector-env functions or none)"
    );
}

#[test]
fn plugin_path_scan_reports_every_rejected_file() {
    let a = c_out_dir("scan-a");
    let b = c_out_dir("scan-b");
    compile_c(CHAIN, &a, "chain", &[]);
    compile_c(HANDSHAKE, &a, "handshake", &[]);
    compile_c(HANDSHAKE, &a, "wrong_major", &["BROKEN_WRONG_MAJOR"]);
    std::fs::write(a.join("README.txt"), "not a library").unwrap();
    std::fs::write(
        a.join(rwg_plugin_host::library_file_name("garbage")),
        "not ELF",
    )
    .unwrap();
    // The same env ids again, in a later directory.
    compile_c(CHAIN, &b, "chain_copy", &[]);
    let missing = a.join("does-not-exist");

    let path = std::env::join_paths([a.clone(), b.clone(), missing.clone()]).unwrap();
    let files = find_plugin_files(&path);
    let names: Vec<String> = files
        .files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let so = |n: &str| rwg_plugin_host::library_file_name(n);
    assert_eq!(
        names,
        [
            so("chain"),
            so("garbage"),
            so("handshake"),
            so("wrong_major"),
            so("chain_copy")
        ]
    );
    assert_eq!(files.rejected.len(), 1);
    assert_eq!(files.rejected[0].path, missing);

    let scan = load_plugin_path(&path);
    let ids: Vec<&str> = scan.plugins.iter().map(|p| p.id()).collect();
    assert_eq!(ids, ["c_example", "handshake"]);
    let rejected: Vec<String> = scan.rejected.iter().map(|r| r.to_string()).collect();
    assert_eq!(rejected.len(), 4, "{rejected:#?}");
    let find = |needle: &str| {
        rejected
            .iter()
            .find(|r| r.contains(needle))
            .unwrap_or_else(|| panic!("no rejection mentions {needle}: {rejected:#?}"))
    };
    assert!(find("does-not-exist").contains("cannot read the plugin directory"));
    assert!(find(&so("garbage")).contains("cannot open the library"));
    assert!(find(&so("wrong_major")).contains("ABI version mismatch"));
    assert!(find(&so("chain_copy")).contains(&format!(
        "environment id 'c_example/Chain-v0' is already provided by {}",
        a.join(so("chain")).display()
    )));

    // Ids the host reserves (its built-ins) reject every file exporting them.
    let scan = load_plugin_path_reserving(&path, &|id| id == "c_example/Chain-v0");
    let ids: Vec<&str> = scan.plugins.iter().map(|p| p.id()).collect();
    assert_eq!(ids, ["handshake"]);
    for f in ["chain", "chain_copy"] {
        let r = scan
            .rejected
            .iter()
            .find(|r| r.path.ends_with(so(f)))
            .unwrap();
        assert_eq!(
            r.reason,
            "environment id 'c_example/Chain-v0' is built into rwg \
             (plugin ids must differ from built-in ones)"
        );
    }
}
