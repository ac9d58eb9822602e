//! The pages cannot drift from the binary and the code: every relative link
//! of the README, `CHANGELOG.md`, `docs/` and the other READMEs resolves
//! (its file, and its `#anchor` to a heading of that file); every
//! `rwg COMMAND --flag` a page shows is in that command's `--help`; every
//! `RWG_*` variable the code reads has a row in the variables table of
//! `docs/guide.md` and every row names one the code reads; every column the
//! binary writes (`scores.csv`, `samples.csv`, `stats.csv`, `rwg compare`'s
//! CSV, and every key of `stats.json` and of `rwg compare`'s JSON) is named
//! on the page that documents it; every JAX env source of rwg-jax's table
//! has its id and install line in the JAX pages; and no paragraph runs past
//! 150 words.

mod common;
use common::*;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The pages users read: the README, the changelog, every Markdown page
/// directly under `docs/` (not the tables `rwg stats` wrote into its
/// folders), every example's README, the peers' and the Python package's,
/// as paths relative to the repository.
fn pages() -> Vec<String> {
    let mut out = vec!["README.md".to_string(), "CHANGELOG.md".to_string()];
    for dir in ["docs", "examples"] {
        let mut found: Vec<String> = std::fs::read_dir(repo().join(dir))
            .unwrap()
            .flat_map(|e| {
                let e = e.unwrap();
                let name = e.file_name().into_string().unwrap();
                if e.file_type().unwrap().is_dir() {
                    let readme = format!("{dir}/{name}/README.md");
                    repo().join(&readme).is_file().then_some(readme)
                } else {
                    name.ends_with(".md").then(|| format!("{dir}/{name}"))
                }
            })
            .collect();
        found.sort();
        out.extend(found);
    }
    out.extend(["benches/peers/README.md", "python/README.md"].map(String::from));
    out
}

/// The lines of `text` outside fenced code blocks, with their numbers
/// (1-based), and whether each is inside one.
fn lines_with_fences(text: &str) -> Vec<(usize, &str, bool)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push((i + 1, line, true));
        } else {
            out.push((i + 1, line, fenced));
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, backticks and punctuation
/// dropped (letters, digits, `-` and `_` kept), spaces turned into `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's headings, duplicates numbered as GitHub does
/// (`name`, `name-1`, ...).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = BTreeSet::new();
    for (_, line, fenced) in lines_with_fences(text) {
        if fenced || !line.starts_with('#') {
            continue;
        }
        let base = slug(line.trim_start_matches('#'));
        let n = seen.entry(base.clone()).or_insert(0);
        out.insert(if *n == 0 {
            base.clone()
        } else {
            format!("{base}-{n}")
        });
        *n += 1;
    }
    out
}

/// The targets of the Markdown links and images of `text` outside code
/// (fenced blocks and inline code spans), with their line numbers.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line, fenced) in lines_with_fences(text) {
        if fenced {
            continue;
        }
        // inline code spans are not links
        let prose: String = line
            .split('`')
            .enumerate()
            .map(|(i, part)| if i % 2 == 0 { part } else { "" })
            .collect();
        let mut rest = prose.as_str();
        while let Some(at) = rest.find("](") {
            let tail = &rest[at + 2..];
            let Some(end) = tail.find(')') else { break };
            out.push((n, tail[..end].trim().to_string()));
            rest = &tail[end..];
        }
    }
    out
}

/// The broken relative links of `page` (relative to `root`): `PAGE:LINE:
/// TARGET: why` each.
fn broken_links(root: &Path, page: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root.join(page)).unwrap();
    let dir = root.join(page).parent().unwrap().to_path_buf();
    let mut bad = Vec::new();
    for (line, target) in link_targets(&text) {
        if target.contains("://") || target.starts_with("mailto:") {
            continue;
        }
        let (file, anchor) = match target.split_once('#') {
            Some((f, a)) => (f, Some(a)),
            None => (target.as_str(), None),
        };
        let path = if file.is_empty() {
            root.join(page)
        } else {
            dir.join(file)
        };
        if !path.exists() {
            bad.push(format!("{page}:{line}: {target}: no such file"));
            continue;
        }
        if let Some(anchor) = anchor {
            let is_md = path.extension().is_some_and(|e| e == "md");
            let heads = is_md.then(|| anchors(&std::fs::read_to_string(&path).unwrap()));
            if !heads.is_some_and(|h| h.contains(anchor)) {
                bad.push(format!(
                    "{page}:{line}: {target}: no heading with that anchor"
                ));
            }
        }
    }
    bad
}

#[test]
fn every_relative_link_resolves_to_a_file_and_heading() {
    let links: usize = pages().iter().map(|p| link_targets(&read(p)).len()).sum();
    assert!(links > 50, "only {links} links found on the pages");
    let bad: Vec<String> = pages()
        .iter()
        .flat_map(|p| broken_links(&repo(), p))
        .collect();
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

#[test]
fn the_link_check_finds_a_broken_file_and_a_broken_anchor() {
    let root = temp_dir("docs-links");
    std::fs::create_dir_all(root.join("docs")).unwrap();
    std::fs::write(root.join("docs/a.md"), "# A `page`: here\n\nText.\n").unwrap();
    std::fs::write(
        root.join("docs/b.md"),
        "See [a](a.md#a-page-here), [gone](gone.md), [a](a.md#nowhere),\n\
         `[not](a link)` and [web](https://example.org/x#y).\n\n```sh\n[in](code.md)\n```\n",
    )
    .unwrap();
    let bad = broken_links(&root, "docs/b.md");
    assert_eq!(bad.len(), 2, "{bad:#?}");
    assert!(bad[0].contains("gone.md: no such file"), "{bad:#?}");
    assert!(bad[1].contains("a.md#nowhere: no heading"), "{bad:#?}");
}

/// `rwg`'s subcommands (and `rwg bench`'s), from its `--help`.
fn subcommands(args: &[&str]) -> Vec<String> {
    let mut all = args.to_vec();
    all.push("--help");
    let help = rwg_ok(&all);
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect()
}

/// Every `rwg COMMAND ... --flag` in `text`, in shell blocks and inline code:
/// (line, command words, flag). A command ends at a pipe, `;`, `&&`, a
/// redirection or a comment.
fn shown_flags(text: &str, commands: &[String], bench: &[String]) -> Vec<(usize, String, String)> {
    let mut out = Vec::new();
    for (n, line, fenced) in lines_with_fences(text) {
        let spans: Vec<&str> = if fenced {
            vec![line]
        } else {
            line.split('`').skip(1).step_by(2).collect()
        };
        for span in spans {
            let words: Vec<&str> = span.split_whitespace().collect();
            for (i, w) in words.iter().enumerate() {
                if !(*w == "rwg" || w.ends_with("/rwg")) {
                    continue;
                }
                let Some(cmd) = words
                    .get(i + 1)
                    .filter(|c| commands.contains(&c.to_string()))
                else {
                    continue;
                };
                let mut name = cmd.to_string();
                if *cmd == "bench" {
                    match words.get(i + 2).filter(|s| bench.contains(&s.to_string())) {
                        Some(sub) => name = format!("bench {sub}"),
                        None => continue,
                    }
                }
                for w in &words[i + 2..] {
                    if ["|", ";", "&&", "||", "#", ">", "2>", ">>"].contains(w)
                        || w.starts_with('>')
                    {
                        break;
                    }
                    if let Some(flag) = w.strip_prefix("--").filter(|f| !f.is_empty()) {
                        let flag = flag.split('=').next().unwrap();
                        let flag = flag.trim_end_matches(|c: char| !c.is_alphanumeric());
                        out.push((n, name.clone(), format!("--{flag}")));
                    }
                }
            }
        }
    }
    out
}

#[test]
fn every_flag_a_page_shows_is_in_its_commands_help() {
    let commands = subcommands(&[]);
    let bench = subcommands(&["bench"]);
    assert!(commands.contains(&"run".to_string()), "{commands:?}");
    let mut helps: HashMap<String, String> = HashMap::new();
    let mut bad = Vec::new();
    let mut seen = 0;
    for page in pages() {
        for (line, cmd, flag) in shown_flags(&read(&page), &commands, &bench) {
            seen += 1;
            let help = helps.entry(cmd.clone()).or_insert_with(|| {
                let mut args: Vec<&str> = cmd.split(' ').collect();
                args.push("--help");
                rwg_ok(&args)
            });
            let listed = help
                .split(|c: char| c.is_whitespace() || c == ',')
                .any(|w| w == flag);
            if !listed {
                bad.push(format!(
                    "{page}:{line}: rwg {cmd} {flag}: not in `rwg {cmd} --help`"
                ));
            }
        }
    }
    assert!(seen > 50, "only {seen} flags found on the pages");
    assert!(
        bad.is_empty(),
        "flags the binary does not have:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_flag_check_reads_blocks_and_inline_code() {
    let cmds: Vec<String> = ["run", "bench"].map(String::from).to_vec();
    let bench = vec!["gym".to_string()];
    let text = "Run `rwg run m.toml --samples 8` or `rwg runs --x`.\n```sh\n\
                target/release/rwg bench gym --peer p.py | grep --count x # --no\n```\n";
    let found = shown_flags(text, &cmds, &bench);
    let flags: Vec<(usize, &str, &str)> = found
        .iter()
        .map(|(n, c, f)| (*n, c.as_str(), f.as_str()))
        .collect();
    assert_eq!(flags, [(1, "run", "--samples"), (3, "bench gym", "--peer")]);
}

/// Every `RWG_*` variable the sources read: a string literal naming it where
/// it is read or declared as a variable's name (`const X: &str = "RWG_..."`,
/// clap's `env = "RWG_..."`, `env::var("RWG_...")`, Python's
/// `NAME_VAR = "RWG_..."` and `os.environ`).
fn variables_read() -> BTreeSet<String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if p.is_dir() && name != "tests" && name != "target" {
                walk(&p, out);
            } else if (name.ends_with(".rs") && name != "tests.rs") || name.ends_with(".py") {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    for e in std::fs::read_dir(repo()).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_dir() && name.starts_with("rwg-") {
            walk(&p.join("src"), &mut files);
        }
    }
    walk(&repo().join("python/rwg"), &mut files);
    let mut out = BTreeSet::new();
    for f in files {
        for line in std::fs::read_to_string(&f).unwrap().lines() {
            let reads = [
                "&str = \"RWG_",
                "env = \"RWG_",
                "var(\"RWG_",
                "var_os(\"RWG_",
            ]
            .iter()
            .any(|p| line.contains(p))
                || (f.extension().is_some_and(|e| e == "py")
                    && (line.contains("_VAR = \"RWG_") || line.contains("environ")));
            if !reads {
                continue;
            }
            for part in line.split('"').skip(1).step_by(2) {
                if part.starts_with("RWG_")
                    && part[4..]
                        .chars()
                        .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
                {
                    out.insert(part.to_string());
                }
            }
        }
    }
    out
}

/// The variables with a row in `docs/guide.md`'s table (its first column's
/// backticked names, `=0` dropped).
fn variables_documented() -> BTreeSet<String> {
    let text = read("docs/guide.md");
    let section = text
        .split("\n### Environment variables")
        .nth(1)
        .expect("docs/guide.md has an Environment variables section");
    let section = section.split("\n#").next().unwrap();
    section
        .lines()
        .filter(|l| l.starts_with("| `RWG_"))
        .flat_map(|l| {
            let first = l.split('|').nth(1).unwrap();
            first
                .split('`')
                .skip(1)
                .step_by(2)
                .map(|v| v.split('=').next().unwrap().to_string())
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn every_variable_the_code_reads_is_in_the_table_and_no_other() {
    let read = variables_read();
    assert!(
        read.contains("RWG_PYTHON") && read.contains("RWG_BIN"),
        "{read:?}"
    );
    let table = variables_documented();
    let missing: Vec<_> = read.difference(&table).collect();
    let stale: Vec<_> = table.difference(&read).collect();
    assert!(
        missing.is_empty(),
        "read by the code but not in docs/guide.md's table: {missing:?}"
    );
    assert!(
        stale.is_empty(),
        "in docs/guide.md's table but read nowhere: {stale:?}"
    );
}

/// Every name in a backticked span of `page`: the span, and its parts split
/// at commas and spaces.
fn code_names(page: &str) -> BTreeSet<String> {
    let text = read(page);
    let mut out = BTreeSet::new();
    for span in text.split('`').skip(1).step_by(2) {
        out.insert(span.to_string());
        for part in span.split([',', ' ']) {
            out.insert(part.to_string());
            // `{"kind":` names kind
            let bare = part.trim_matches(|c: char| !(c.is_alphanumeric() || "_.*".contains(c)));
            out.insert(bare.to_string());
        }
    }
    out.remove("");
    out
}

/// Every key of the objects in `v`, nested ones included.
fn json_keys(v: &serde_json::Value, out: &mut BTreeSet<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, v) in m {
                out.insert(k.clone());
                json_keys(v, out);
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|v| json_keys(v, out)),
        _ => {}
    }
}

/// Whether `column` is among `names`, or matches one ending in `*`.
fn documented(column: &str, names: &BTreeSet<String>) -> bool {
    names.contains(column)
        || names
            .iter()
            .filter_map(|n| n.strip_suffix('*'))
            .any(|prefix| !prefix.is_empty() && column.starts_with(prefix))
}

fn header(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect()
}

#[test]
fn every_column_the_binary_writes_is_documented() {
    let dir = temp_dir("docs-columns");
    let manifest = dir.join("m.toml");
    std::fs::write(
        &manifest,
        "seed = 0\nsamples = 8\nepisodes = 2\nbias = [false]\n\
         [[architectures]]\nname = \"0HL\"\nhidden = []\n\
         [[envs]]\nid = \"CartPole-v0\"\nsolved = 195\n",
    )
    .unwrap();
    let (a, b) = (dir.join("a"), dir.join("b"));
    for (out, seed) in [(&a, "0"), (&b, "1")] {
        let (m, o) = (manifest.to_str().unwrap(), out.to_str().unwrap());
        rwg_ok(&["run", m, "--out", o, "--seed", seed, "--no-report"]);
    }
    let a_s = a.to_str().unwrap();
    rwg_ok(&["stats", a_s, "--at-n", "4"]);
    let cell = a.join("cells/CartPole-v0__0HL__nobias");
    let b_s = b.to_str().unwrap();
    // the first line of a CSV text, split
    let columns = |csv: String| -> Vec<String> {
        let first = csv.lines().next().unwrap_or_default().to_string();
        first.split(',').map(String::from).collect()
    };
    let compare_cols = columns(rwg_ok(&["compare", a_s, b_s, "--format", "csv"]));
    let json_of = |text: &str| {
        let mut keys = BTreeSet::new();
        json_keys(&serde_json::from_str(text).unwrap(), &mut keys);
        keys.into_iter().collect::<Vec<String>>()
    };
    let paired = |format: &str| {
        rwg_ok(&[
            "compare",
            a_s,
            b_s,
            "--paired",
            "CartPole-v0",
            "CartPole-v0",
            "--format",
            format,
        ])
    };
    let paired_cols = columns(paired("csv"));
    let paired_keys = json_of(&paired("json"));
    let stats_keys = json_of(&std::fs::read_to_string(a.join("stats.json")).unwrap());
    let compare_keys = json_of(&rwg_ok(&["compare", a_s, b_s, "--format", "json"]));
    let (guide, both) = (
        &["docs/guide.md"][..],
        &["docs/guide.md", "docs/reference.md"][..],
    );
    let written = [
        ("scores.csv", header(&cell.join("scores.csv")), guide),
        ("samples.csv", header(&cell.join("samples.csv")), guide),
        ("stats.csv", header(&a.join("stats.csv")), guide),
        (
            "rwg compare --format csv",
            compare_cols,
            &["docs/reference.md"][..],
        ),
        ("stats.json", stats_keys, both),
        ("rwg compare --format json", compare_keys, both),
        (
            "rwg compare --paired --format csv",
            paired_cols,
            &["docs/reference.md"][..],
        ),
        (
            "rwg compare --paired --format json",
            paired_keys,
            &["docs/reference.md"][..],
        ),
    ];
    let mut bad = Vec::new();
    for (what, columns, pages) in written {
        assert!(columns.len() >= 4, "{what}: {columns:?}");
        let names: BTreeSet<String> = pages.iter().flat_map(|p| code_names(p)).collect();
        for c in columns.iter().filter(|c| !documented(c, &names)) {
            bad.push(format!(
                "{what}: `{c}` is not named in {}",
                pages.join(" or ")
            ));
        }
    }
    assert!(bad.is_empty(), "undocumented columns:\n{}", bad.join("\n"));
}

/// The paragraphs of `text` longer than `limit` words: prose outside code
/// blocks and tables, a list item counting as a paragraph of its own.
fn long_paragraphs(text: &str, limit: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut current: Option<(usize, usize)> = None;
    let mut close = |p: &mut Option<(usize, usize)>| {
        if let Some((start, words)) = p.take() {
            if words > limit {
                out.push((start, words));
            }
        }
    };
    for (n, line, fenced) in lines_with_fences(text) {
        let t = line.trim_start();
        let item = t.starts_with("- ")
            || t.starts_with("* ")
            || t.split_once(". ")
                .is_some_and(|(d, _)| !d.is_empty() && d.chars().all(|c| c.is_ascii_digit()));
        if fenced || t.is_empty() || t.starts_with('|') || t.starts_with('#') || item {
            close(&mut current);
            if fenced || t.is_empty() || t.starts_with('|') || t.starts_with('#') {
                continue;
            }
        }
        let words = t.split_whitespace().count();
        match &mut current {
            Some((_, w)) => *w += words,
            None => current = Some((n, words)),
        }
    }
    close(&mut current);
    out
}

#[test]
fn no_paragraph_runs_past_150_words() {
    let mut bad = Vec::new();
    for page in pages().into_iter().chain(["ARCHITECTURE.md".to_string()]) {
        for (line, words) in long_paragraphs(&read(&page), 150) {
            bad.push(format!("{page}:{line}: {words} words"));
        }
    }
    assert!(
        bad.is_empty(),
        "paragraphs over 150 words:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_paragraph_check_counts_prose_and_list_items_apart() {
    let long = "word ".repeat(151);
    let text = format!("# T\n\n{long}\n\n- short\n- {long}\n\n| {long} |\n\n```sh\n{long}\n```\n");
    assert_eq!(long_paragraphs(&text, 150), [(3, 151), (6, 152)]);
}

/// Every JAX env source of rwg-jax's table ([`rwg_jax::FAMILIES`]) is on
/// the JAX pages: its id form, and for a library a tested `pip install`
/// line pinning its package; the six families each have a section of
/// `docs/jax-families.md` named for the library.
#[test]
fn every_jax_source_of_the_table_is_documented() {
    let pages = format!("{}{}", read("docs/jax.md"), read("docs/jax-families.md"));
    let families = read("docs/jax-families.md");
    let mut bad = vec![];
    for f in rwg_jax::FAMILIES.iter() {
        let id = |quote: char| pages.contains(&format!("{quote}{}", f.prefix));
        if !id('`') && !id('"') {
            bad.push(format!("{}: no id `{}...`", f.library, f.prefix));
        }
        let pinned = format!(" {}==", f.package);
        if !f.package.is_empty()
            && !families
                .lines()
                .any(|l| l.starts_with("python3 -m pip install") && l.contains(&pinned))
        {
            bad.push(format!("{}: no install line with{pinned}", f.library));
        }
        let base = ["gymnax", "brax", "jax"].contains(&f.source);
        if !base && !families.contains(&format!("\n## {}\n", f.library)) {
            bad.push(format!("{}: no section `## {}`", f.library, f.library));
        }
    }
    assert!(
        bad.is_empty(),
        "JAX sources missing from the docs:\n{}",
        bad.join("\n")
    );
}
