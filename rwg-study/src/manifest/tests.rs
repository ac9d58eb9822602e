use super::*;

const GOOD: &str = r#"
seed = 3
samples = 10
episodes = 2
bias = [false, true]

[weights]
distribution = "uniform"
scale = 2

[[architectures]]
name = "0HL"
hidden = []

[[architectures]]
name = "2HL"
hidden = [4, 4]

[[envs]]
id = "CartPole-v0"
solved = 195

[[envs]]
id = "Pendulum-v0"
solved = -140.5
action_dtype = "float32"
plugin = "libs/x.so"
config = "a=1"
"#;

fn parse(text: &str) -> Result<Manifest, ManifestError> {
    Manifest::parse(text, "m.toml", Path::new("/base"))
}

#[test]
fn parses_a_full_manifest() {
    let m = parse(GOOD).unwrap();
    assert_eq!((m.seed, m.samples, m.episodes), (3, 10, 2));
    assert_eq!(m.bias, [false, true]);
    assert_eq!(m.weights, WeightDist::Uniform { a: 2.0 });
    assert_eq!(m.architectures[1].hidden, [4, 4]);
    assert_eq!(m.envs[0].solved, Some(195.0));
    assert_eq!(m.envs[1].action_dtype, Some(ActionDtype::F32));
    assert_eq!(
        m.envs[1].plugin.as_deref(),
        Some(Path::new("/base/libs/x.so"))
    );
    assert_eq!(&GOOD[m.envs[1].id_span.clone()], "\"Pendulum-v0\"");
    assert_eq!(
        &GOOD[m.envs[1].plugin_span.clone().unwrap()],
        "\"libs/x.so\""
    );
    assert_eq!(m.envs[1].config.as_deref(), Some("a=1"));
    assert_eq!(m.envs[0].plugin_span, None);
}

#[test]
fn resolved_toml_round_trips() {
    let m = parse(GOOD).unwrap();
    let again = parse(&m.to_toml()).unwrap();
    assert_eq!(
        again.envs.iter().map(|e| &e.id).collect::<Vec<_>>(),
        ["CartPole-v0", "Pendulum-v0"]
    );
    assert_eq!(again.weights, m.weights);
    assert_eq!(again.architectures, m.architectures);
    assert_eq!(again.bias, m.bias);
    assert_eq!(again.envs[1].solved, Some(-140.5));
    assert_eq!(again.envs[1].config.as_deref(), Some("a=1"));
    assert_eq!(again.envs[1].plugin, m.envs[1].plugin);
    assert!(m.study_differences(&again).is_empty());
    let other = parse(&GOOD.replace("episodes = 2", "episodes = 3")).unwrap();
    assert_eq!(m.study_differences(&other), ["episodes: 2 vs 3"]);
}

fn error_of(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

#[test]
fn errors_name_file_line_column_and_key() {
    let e = error_of(&GOOD.replace("samples = 10", "samples = 0"));
    assert_eq!(e, "m.toml:3:11: samples: must be at least 1, got 0");
    let e = error_of(&GOOD.replace("hidden = [4, 4]", "hidden = [4, 0]"));
    assert!(
        e.starts_with("m.toml:17:14: architectures[1].hidden[1]: a layer needs"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("\"uniform\"", "\"cauchy\""));
    assert!(
        e.starts_with("m.toml:8:16: weights.distribution: unknown distribution 'cauchy'"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("action_dtype = \"float32\"", "action_dtype = \"int8\""));
    assert!(
        e.starts_with("m.toml:26:16: envs[1].action_dtype: unknown action dtype"),
        "{e}"
    );
}

#[test]
fn unknown_keys_are_errors_with_a_suggestion() {
    let e = error_of(&GOOD.replace("episodes = 2", "episodes = 2\nsampels = 4"));
    assert!(
        e.starts_with("m.toml:5:1: sampels: unknown key `sampels`"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("solved = 195", "solve = 195"));
    assert!(
        e.contains("envs[0].solve: unknown key `solve`") && e.contains("did you mean `solved`"),
        "{e}"
    );
}

#[test]
fn type_errors_and_missing_keys() {
    let e = error_of(&GOOD.replace("samples = 10", "samples = \"many\""));
    assert!(e.starts_with("m.toml:3:11:"), "{e}");
    let e = error_of(&GOOD.replace("episodes = 2\n", ""));
    assert!(e.contains("missing key `episodes`"), "{e}");
}

/// Issue 12: type errors named no key (`invalid type: string "0",
/// expected i64`; `data did not match any variant of untagged enum Num`).
#[test]
fn type_errors_name_the_key_path_and_the_accepted_forms() {
    let text = GOOD.replace(
        "solved = -140.5",
        "solved = -140.5\nmax_episode_steps = \"0\"",
    );
    assert_eq!(
        error_of(&text),
        "m.toml:26:21: envs[1].max_episode_steps: expected an integer, found the string \"0\""
    );
    let e = error_of(&GOOD.replace("solved = 195", "solved = \"high\""));
    assert_eq!(
        e,
        "m.toml:21:10: envs[0].solved: expected a number (an integer such as 195 or a \
             float such as -140.5), found the string \"high\""
    );
    assert!(!e.contains("untagged"), "{e}");
    let e = error_of(&GOOD.replace("scale = 2", "scale = true"));
    assert!(
        e.starts_with("m.toml:9:9: weights.scale: expected a number"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("hidden = [4, 4]", "hidden = [4, \"4\"]"));
    assert_eq!(
        e,
        "m.toml:17:14: architectures[1].hidden[1]: expected an integer, found the string \"4\""
    );
    let e = error_of(&GOOD.replace("bias = [false, true]", "bias = [0]"));
    assert_eq!(
        e,
        "m.toml:5:9: bias[0]: expected true or false, found the integer 0"
    );
    let e = error_of(&GOOD.replace("id = \"CartPole-v0\"\n", ""));
    assert!(e.contains("envs[0]: missing key `id`"), "{e}");
}

/// Issue 12: binary and UTF-16 manifests got no position.
#[test]
fn non_utf8_files_get_a_position() {
    let dir = std::env::temp_dir().join(format!("rwg-manifest-bytes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("m.toml");
    let mut utf16 = vec![0xFF, 0xFE];
    for u in GOOD.encode_utf16() {
        utf16.extend(u.to_le_bytes());
    }
    std::fs::write(&p, &utf16).unwrap();
    let e = Manifest::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("m.toml:1:1: the file starts with a UTF-16 byte-order mark"),
        "{e}"
    );
    std::fs::write(&p, &utf16[2..]).unwrap();
    let e = Manifest::load(&p).unwrap_err().to_string();
    assert!(e.contains("m.toml:2:1: a NUL byte"), "{e}");
    assert!(e.ends_with("the manifest must be UTF-8 TOML"), "{e}");
    let mut bad = GOOD.as_bytes().to_vec();
    bad[GOOD.find("samples").unwrap() + 2] = 0xC3;
    std::fs::write(&p, &bad).unwrap();
    let e = Manifest::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("m.toml:3:3: byte 0xC3 is not UTF-8; the manifest must be UTF-8 TOML"),
        "{e}"
    );
    std::fs::write(&p, [0x7F, b'E', b'L', b'F', 2, 1, 1, 0]).unwrap();
    let e = Manifest::load(&p).unwrap_err().to_string();
    assert!(e.contains("m.toml:1:8: a NUL byte"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 12: `episodes = 4294967295` aborted on allocation, a
/// 5000-character architecture name failed only at run time.
#[test]
fn counts_sizes_and_names_are_limited() {
    let e = error_of(&GOOD.replace("episodes = 2", "episodes = 4294967295"));
    assert_eq!(
        e,
        "m.toml:4:12: episodes: at most 10000 (rwg's limit), got 4294967295"
    );
    let e = error_of(&GOOD.replace("samples = 10", "samples = 9223372036854775807"));
    assert_eq!(
        e,
        "m.toml:3:11: samples: at most 10000000 (rwg's limit), got 9223372036854775807"
    );
    let e = error_of(&GOOD.replace("bias = [false, true]", "threads = 100000"));
    assert_eq!(
        e,
        "m.toml:5:11: threads: at most 1024 (rwg's limit), got 100000"
    );
    let e = error_of(&GOOD.replace(
        "name = \"2HL\"",
        &format!("name = \"{}\"", "a".repeat(5000)),
    ));
    assert_eq!(
        e,
        "m.toml:16:8: architectures[1].name: at most 64 bytes (rwg's limit), got 5000"
    );
    let e = error_of(&GOOD.replace("hidden = [4, 4]", "hidden = [4, 5000]"));
    assert!(
        e.contains(
            "architectures[1].hidden[1]: a layer needs 1 to 4096 units (rwg's limit), got 5000"
        ),
        "{e}"
    );
    let e = error_of(&GOOD.replace(
        "hidden = [4, 4]",
        &format!("hidden = [{}]", ["1"; 65].join(",")),
    ));
    assert!(
        e.contains("architectures[1].hidden: at most 64 layers (rwg's limit), got 65"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("solved = 195", "max_episode_steps = 4294967296"));
    assert!(
        e.contains("envs[0].max_episode_steps: at most 10000000 (rwg's limit), got 4294967296"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("\"a=1\"", &format!("\"{}\"", "x".repeat(70000))));
    assert!(
        e.contains("envs[1].config: at most 65536 bytes (rwg's limit), got 70000"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("Pendulum-v0", &"P".repeat(200)));
    assert!(
        e.contains("envs[1].id: at most 128 bytes (rwg's limit), got 200"),
        "{e}"
    );
    let many: String = (0..257)
        .map(|i| format!("[[architectures]]\nname = \"a{i}\"\nhidden = []\n"))
        .collect();
    let e = error_of(&GOOD.replace("[[architectures]]\nname = \"0HL\"\nhidden = []\n", &many));
    assert!(
        e.contains("architectures: at most 256 (rwg's limit), got 258"),
        "{e}"
    );
    let many: String = (0..257)
        .map(|i| format!("[[envs]]\nid = \"e{i}\"\n"))
        .collect();
    let e = error_of(&format!("{GOOD}{many}"));
    assert!(
        e.contains("envs: at most 256 (rwg's limit), got 259"),
        "{e}"
    );
}

#[test]
fn duplicate_env_and_empty_lists() {
    let e = error_of(&GOOD.replace("Pendulum-v0", "CartPole-v0"));
    assert!(
        e.contains("envs[1].id: 'CartPole-v0' is listed twice"),
        "{e}"
    );
    let e = error_of(&GOOD.replace("bias = [false, true]", "bias = []"));
    assert!(e.contains("bias: needs at least one"), "{e}");
}

#[test]
fn a_bias_setting_given_twice_is_refused_wherever_it_stands() {
    for twice in [
        "[true, true]",
        "[false, true, false]",
        "[true, false, true]",
    ] {
        let e = error_of(&GOOD.replace("[false, true]", twice));
        assert_eq!(
            e, "m.toml:5:8: bias: each setting may appear once",
            "{twice}"
        );
    }
}

#[test]
fn isolate_is_how_an_env_runs_not_part_of_the_study() {
    let m = parse(GOOD).unwrap();
    assert!(m.envs.iter().all(|e| !e.isolate));
    let with = GOOD.replace("config = \"a=1\"", "config = \"a=1\"\nisolate = true");
    assert_ne!(with, GOOD);
    let iso = parse(&with).unwrap();
    assert!(iso.envs[1].isolate);
    // written out (rwg slurm's shards read it back), yet the same study
    assert!(iso.to_toml().contains("isolate = true"));
    assert!(!m.to_toml().contains("isolate"));
    let again = parse(&iso.to_toml()).unwrap();
    assert!(again.envs[1].isolate);
    assert!(m.study_differences(&iso).is_empty());
    let e = error_of(&GOOD.replace("config = \"a=1\"", "config = \"a=1\"\nisolate = 1"));
    assert!(
        e.contains(": envs[1].isolate: expected true or false"),
        "{e}"
    );
}

#[test]
fn a_gymnasium_id_listed_twice_names_the_way_out() {
    // the same id with other kwargs would give the same seeds and cell names
    let two = "[[envs]]\nid = \"gymnasium:LunarLander-v3\"\n\n\
               [[envs]]\nid = \"gymnasium:LunarLander-v3\"\nkwargs = { continuous = true }\n";
    let e = error_of(&format!("{GOOD}{two}"));
    assert!(
        e.starts_with("m.toml:33:6: envs[3].id: 'gymnasium:LunarLander-v3' is listed twice"),
        "{e}"
    );
    assert!(e.contains("gymnasium:LunarLanderContinuous-v3"), "{e}");
}

/// A study of one JAX env with `extra` lines in its entry.
fn jax_study(id: &str, extra: &str) -> String {
    format!(
        "samples = 10\nepisodes = 2\n[[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"{id}\"\n{extra}\n"
    )
}

#[test]
fn jax_envs_write_their_precisions_into_the_study_not_their_call_size() {
    let m = parse(&jax_study("gymnax:CartPole-v1", "")).unwrap();
    assert_eq!(m.envs[0].precision, Some(rwg_jax::Precision::F32));
    assert_eq!(
        m.envs[0].matmul_precision,
        Some(rwg_jax::MatmulPrecision::Highest)
    );
    for line in ["precision = \"float32\"", "matmul_precision = \"highest\""] {
        assert!(m.to_toml().contains(line), "{line}: {}", m.to_toml());
    }
    // an explicit float32 (or highest) is the default's study
    let f32 = parse(&jax_study(
        "gymnax:CartPole-v1",
        "precision = \"float32\"\nmatmul_precision = \"highest\"",
    ))
    .unwrap();
    assert!(m.study_differences(&f32).is_empty());
    for (key, value) in [("precision", "float64"), ("matmul_precision", "default")] {
        let o = parse(&jax_study(
            "gymnax:CartPole-v1",
            &format!("{key} = \"{value}\""),
        ))
        .unwrap();
        let d = m.study_differences(&o);
        assert!(d.len() == 1 && d[0].contains(value), "{d:?}");
    }
    // networks per call is written back, and is how, not what (as the
    // device): the default's study, a resume may change it
    let calls = parse(&jax_study("brax:ant", "networks_per_call = 64")).unwrap();
    let again = parse(&calls.to_toml()).unwrap();
    assert_eq!(again.envs[0].networks_per_call, Some(64));
    let other = parse(&jax_study("brax:ant", "networks_per_call = 128")).unwrap();
    assert!(calls.study_differences(&other).is_empty());
    let default = parse(&jax_study("brax:ant", "")).unwrap();
    assert!(calls.study_differences(&default).is_empty());
    let gpu = parse(&jax_study(
        "brax:ant",
        "networks_per_call = 64\ndevice = \"gpu:1\"",
    ))
    .unwrap();
    assert_eq!(gpu.envs[0].device.as_deref(), Some("gpu:1"));
    assert!(gpu.to_toml().contains("device = \"gpu:1\""));
    assert!(calls.study_differences(&gpu).is_empty());
    // built-in envs have none of it
    let b = parse(GOOD).unwrap();
    assert!(b
        .envs
        .iter()
        .all(|e| e.precision.is_none() && e.matmul_precision.is_none()));
    assert!(!b.to_toml().contains("precision"));
}

#[test]
fn jax_keys_are_checked_where_they_stand() {
    for (id, extra, says) in [
        (
            "gymnax:CartPole-v1",
            "precision = \"float16\"",
            "m.toml:8:13: envs[0].precision: expected \"float32\" or \"float64\"",
        ),
        (
            "gymnax:CartPole-v1",
            "matmul_precision = \"tf32\"",
            "m.toml:8:20: envs[0].matmul_precision: expected \"highest\"",
        ),
        (
            "gymnax:CartPole-v1",
            "networks_per_call = 33",
            "m.toml:8:21: envs[0].networks_per_call: must be a multiple of 32",
        ),
        (
            "gymnax:CartPole-v1",
            "networks_per_call = 0",
            "envs[0].networks_per_call: must be a multiple of 32",
        ),
        (
            "gymnax:CartPole-v1",
            "networks_per_call = 131072",
            "to 65536 (rwg's limit), got 131072",
        ),
        (
            "gymnax:CartPole-v1",
            "device = \"gpu:x\"",
            "m.toml:8:10: envs[0].device: expected a JAX device kind",
        ),
        (
            "gymnax:CartPole-v1",
            "device = \"\"",
            "envs[0].device: expected",
        ),
        (
            "gymnax:CartPole-v1",
            "plugin = \"x.so\"",
            "m.toml:8:10: envs[0].plugin: 'gymnax:CartPole-v1' is a JAX environment",
        ),
        (
            "brax:ant",
            "config = \"a\"",
            "envs[0].config: 'brax:ant' is a JAX environment",
        ),
        (
            "brax:ant",
            "isolate = true",
            "envs[0].isolate: 'brax:ant' is a JAX environment",
        ),
        (
            "jax:m:f",
            "action_dtype = \"float32\"",
            "envs[0].action_dtype: 'jax:m:f' is a JAX environment",
        ),
        (
            "gymnax:CartPole-v1",
            "action_dtype = \"float64\"",
            "envs[0].action_dtype: 'gymnax:CartPole-v1' is a JAX environment",
        ),
        (
            "jax:my_module",
            "",
            "m.toml:7:6: envs[0].id: 'jax:my_module' names no callable",
        ),
        (
            "CartPole-v1",
            "precision = \"float64\"",
            "m.toml:8:13: envs[0].precision: applies to JAX environments only",
        ),
        (
            "gymnasium:Ant-v5",
            "device = \"cpu\"",
            "envs[0].device: applies to JAX environments only",
        ),
        (
            "CartPole-v1",
            "matmul_precision = \"high\"",
            "envs[0].matmul_precision: applies to JAX environments only",
        ),
        (
            "CartPole-v1",
            "networks_per_call = 32",
            "envs[0].networks_per_call: applies to JAX",
        ),
        (
            "gymnasium:CartPole-v1",
            "action_mask = false",
            "envs[0].action_mask: applies to JAX environments only (ids gymnax:ID, brax:NAME, \
             playground:NAME, jumanji:ID, craftax:NAME, navix:ID, xminigrid:ID, pgx:ID, \
             jax:module:callable)",
        ),
        ("pgx:2048", "action_mask = \"no\"", "envs[0].action_mask"),
    ] {
        let e = error_of(&jax_study(id, extra));
        assert!(e.contains(says), "{id} {extra}: {e}");
    }
    for ok in ["cpu", "gpu", "gpu:1", "tpu:0", "cuda"] {
        parse(&jax_study(
            "gymnax:CartPole-v1",
            &format!("device = \"{ok}\""),
        ))
        .unwrap();
    }
}

/// `action_mask` on a JAX env of a family: the manifest keeps `false` (part
/// of the study) and leaves out the default.
#[test]
fn action_mask_is_a_jax_key_written_only_when_off() {
    let off = parse(&jax_study("pgx:2048", "action_mask = false")).unwrap();
    assert_eq!(off.envs[0].action_mask, Some(false));
    let on = parse(&jax_study("pgx:2048", "")).unwrap();
    assert_eq!(on.envs[0].action_mask, Some(true));
    assert!(!on.to_toml().contains("action_mask"), "{}", on.to_toml());
    assert_eq!(
        parse(&off.to_toml()).unwrap().envs[0].action_mask,
        Some(false)
    );
    assert_eq!(
        on.study_differences(&off).len(),
        1,
        "{:?}",
        on.study_differences(&off)
    );
    let builtin = parse(GOOD).unwrap();
    assert!(builtin.envs.iter().all(|e| e.action_mask.is_none()));
}

#[test]
fn isolate_all_leaves_jax_envs_alone() {
    let two = format!("{GOOD}[[envs]]\nid = \"gymnax:CartPole-v1\"\n");
    let mut m = parse(&two).unwrap();
    m.isolate_all();
    let isolated: Vec<bool> = m.envs.iter().map(|e| e.isolate).collect();
    assert_eq!(isolated, [true, true, false]);
    parse(&m.to_toml()).unwrap();
}

/// The cause of an unreadable manifest is chained, not also printed: a
/// chain printer (`rwg`'s `error: a: b`) shows it once.
#[test]
fn an_unreadable_manifest_chains_its_cause_without_printing_it() {
    use std::error::Error;
    let e = Manifest::load(std::path::Path::new("/nonexistent-rwg-dir/m.toml")).unwrap_err();
    let cause = e.source().expect("the I/O error is the source").to_string();
    assert!(!e.to_string().contains(&cause), "{e} repeats {cause}");
    assert!(e.to_string().starts_with("cannot read manifest "), "{e}");
}

#[test]
fn a_random_architecture_has_no_layers_and_reads_back() {
    let text = GOOD.replace(
        "[[envs]]\nid = \"CartPole-v0\"",
        "[[architectures]]\nname = \"random\"\npolicy = \"random\"\n\n[[envs]]\nid = \"CartPole-v0\"",
    );
    let m = parse(&text).unwrap();
    let r = &m.architectures[2];
    assert_eq!((r.name.as_str(), r.policy), ("random", PolicyKind::Random));
    assert!(r.hidden.is_empty());
    assert_eq!(m.architectures[0].policy, PolicyKind::Network);
    let toml = m.to_toml();
    assert_eq!(toml.matches("policy = \"random\"").count(), 1, "{toml}");
    assert!(
        !toml.contains("\"network\""),
        "networks write no policy: {toml}"
    );
    let again = parse(&toml).unwrap();
    assert_eq!(again.architectures, m.architectures);
    assert!(m.study_differences(&again).is_empty());
    // hidden = [] and policy = "network" are the same as leaving them out
    let spelled = text.replace("policy = \"random\"", "policy = \"random\"\nhidden = []");
    assert_eq!(parse(&spelled).unwrap().architectures, m.architectures);
    let net = GOOD.replace("hidden = []", "hidden = []\npolicy = \"network\"");
    assert!(parse(GOOD)
        .unwrap()
        .study_differences(&parse(&net).unwrap())
        .is_empty());
    // the random cell is part of the study
    assert_eq!(
        parse(GOOD).unwrap().study_differences(&m).len(),
        1,
        "architectures differ"
    );
}

#[test]
fn random_architectures_are_checked_where_they_stand() {
    let with = |arch: &str| GOOD.replace("name = \"2HL\"\nhidden = [4, 4]", arch);
    let e = error_of(&with("name = \"r\"\npolicy = \"random\"\nhidden = [4]"));
    assert!(
        e.starts_with("m.toml:18:10: architectures[1].hidden: policy = \"random\" runs no network"),
        "{e}"
    );
    let e = error_of(&with("name = \"r\"\npolicy = \"uniform\""));
    assert!(
        e.starts_with("m.toml:17:10: architectures[1].policy: \"network\" (tanh networks"),
        "{e}"
    );
    assert!(e.ends_with("got \"uniform\""), "{e}");
    let e = error_of(&with("name = \"r\""));
    assert!(
        e.starts_with("m.toml:16:8: architectures[1]: missing key `hidden`")
            && e.contains("policy = \"random\""),
        "{e}"
    );
    let e = error_of(&with("name = \"r\"\npolicy = 1"));
    assert!(
        e.starts_with("m.toml:17:10: architectures[1].policy:"),
        "{e}"
    );
}
