//! ARCHITECTURE.md's crate table against the `Cargo.toml` files: every
//! workspace member has a row (its folder or one above it), a row's
//! "depends on" cell names exactly the rwg crates its members depend on
//! (`[dependencies]`, optional ones included; not dev- or build-
//! dependencies), each of them in a row above it, and every other name in
//! the cell is one of those members' dependencies. So the map cannot drift
//! from the build.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The quoted strings of the root `Cargo.toml`'s `members = [...]`.
fn members(root_toml: &str) -> Vec<String> {
    let start = root_toml.find("members = [").expect("a members list");
    let list = &root_toml[start..];
    let list = &list[..list.find(']').expect("the members list's end")];
    list.split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The keys of a `Cargo.toml`'s `[dependencies]` table (`name = ...` or
/// `name.workspace = true`).
fn dependencies(toml: &str) -> BTreeSet<String> {
    let mut in_deps = false;
    let mut deps = BTreeSet::new();
    for line in toml.lines().map(str::trim) {
        if line.starts_with('[') {
            in_deps = line == "[dependencies]";
            continue;
        }
        if !in_deps || line.is_empty() || line.starts_with('#') {
            continue;
        }
        let key = line.split(['=', '.']).next().unwrap().trim();
        deps.insert(key.to_string());
    }
    deps
}

/// One crate row of the table: its folder, its line, its "depends on" names.
struct Row {
    dir: String,
    line: usize,
    names: Vec<String>,
}

/// The table's rows whose first cell is a folder (`` `name/` ``), in order.
fn rows(arch: &str) -> Vec<Row> {
    let mut rows = Vec::new();
    for (i, line) in arch.lines().enumerate() {
        let cells: Vec<&str> = line.trim_matches('|').split(" | ").collect();
        if !line.starts_with("| `") || cells.len() != 3 {
            continue;
        }
        let dir = cells[0].trim().trim_matches('`');
        if !dir.ends_with('/') {
            continue;
        }
        let names = cells[2]
            .split([',', ';'])
            .map(|n| n.replace("(optional)", "").trim().to_string())
            .filter(|n| !n.is_empty() && n != "nothing")
            .collect();
        rows.push(Row {
            dir: dir.to_string(),
            line: i + 1,
            names,
        });
    }
    rows
}

#[test]
fn the_crate_table_matches_the_cargo_files() {
    let root = repo();
    let arch = read(&root.join("ARCHITECTURE.md"));
    let rows = rows(&arch);
    // Each member's folder, package name and dependencies.
    let mut by_member: BTreeMap<String, (String, BTreeSet<String>)> = BTreeMap::new();
    for m in members(&read(&root.join("Cargo.toml"))) {
        let toml = read(&root.join(&m).join("Cargo.toml"));
        let name = toml
            .lines()
            .find_map(|l| l.strip_prefix("name = \""))
            .and_then(|l| l.strip_suffix('"'))
            .unwrap_or_else(|| panic!("{m}/Cargo.toml: no package name"))
            .to_string();
        by_member.insert(format!("{m}/"), (name, dependencies(&toml)));
    }
    let mut above: BTreeSet<String> = BTreeSet::new();
    let mut covered: BTreeSet<String> = BTreeSet::new();
    for row in &rows {
        let at = format!("ARCHITECTURE.md:{} ({})", row.line, row.dir);
        let mine: Vec<_> = by_member
            .iter()
            .filter(|(dir, _)| dir.starts_with(&row.dir))
            .collect();
        if mine.is_empty() {
            continue; // not a crate (python/, benches/peers/, tests/)
        }
        let own: BTreeSet<&str> = mine.iter().map(|(_, (n, _))| n.as_str()).collect();
        let deps: BTreeSet<&str> = mine
            .iter()
            .flat_map(|(_, (_, d))| d.iter().map(String::as_str))
            .collect();
        let want: BTreeSet<&str> = deps
            .iter()
            .copied()
            .filter(|d| d.starts_with("rwg-") && !own.contains(d))
            .collect();
        let named: BTreeSet<&str> = row
            .names
            .iter()
            .map(String::as_str)
            .filter(|n| n.starts_with("rwg-"))
            .collect();
        assert_eq!(named, want, "{at}: the rwg crates it depends on");
        for n in &row.names {
            assert!(deps.contains(n.as_str()), "{at}: {n} is not a dependency");
        }
        for d in &want {
            assert!(above.contains(*d), "{at}: {d} is not in a row above");
        }
        above.extend(own.iter().map(|n| n.to_string()));
        covered.extend(mine.iter().map(|(dir, _)| dir.to_string()));
    }
    let missing: Vec<_> = by_member.keys().filter(|m| !covered.contains(*m)).collect();
    assert!(
        missing.is_empty(),
        "workspace members without a row: {missing:?}"
    );
}

#[test]
fn the_helpers_read_what_they_should() {
    assert_eq!(
        members("members = [\n  \"a\",\n  \"b/c\",\n]"),
        ["a", "b/c"]
    );
    let deps = dependencies(
        "[package]\nname = \"x\"\n\n[dependencies]\na.workspace = true\nb = { path = \"b\" }\n\
         # c = 1\n\n[dev-dependencies]\nd = \"1\"\n",
    );
    assert_eq!(deps, BTreeSet::from(["a".to_string(), "b".to_string()]));
    let r = rows(
        "| crate | owns | depends on |\n|---|---|---|\n| `x/` | it | a (optional), b |\n\
                  | `y/` | it | nothing |\n| `z.txt` | not a folder | a |\n",
    );
    assert_eq!(r.len(), 2);
    assert_eq!(r[0].names, ["a", "b"]);
    assert!(r[1].names.is_empty());
}
