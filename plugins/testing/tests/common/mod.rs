//! Finding and building the plugin libraries the tests load.
//!
//! Rust plugins: cargo builds a package's cdylib before its integration
//! tests (the packages are `cdylib` + `rlib`), into the target dir's
//! `<profile>/deps/` (or `<profile>/` after `cargo build`). The test binary
//! runs from `<profile>/deps/`, so the libraries are found relative to it,
//! whatever `CARGO_TARGET_DIR` is.
//!
//! C plugins: compiled here with the system C compiler (`cc`, or `$CC`) into
//! `<profile>/rwg-c-plugins/<test>/`.

#![allow(dead_code, reason = "each test file uses part of these helpers")]

use std::path::{Path, PathBuf};
use std::process::Command;

use rwg_plugin_host::library_file_name;

/// `<target>/<profile>/deps`, where this test binary lives.
pub fn deps_dir() -> PathBuf {
    std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The built Rust cdylib `name` (e.g. `rwg_testing_plugins`).
pub fn rust_plugin(name: &str, package: &str) -> PathBuf {
    let deps = deps_dir();
    let file = library_file_name(name);
    [deps.parent().unwrap(), &deps]
        .iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "{file} not found near {}: run `cargo build -p {package}` \
                 (or `cargo test -p {package}`, which builds it)",
                deps.display()
            )
        })
}

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fresh, empty directory for one test's compiled C plugins.
pub fn c_out_dir(test: &str) -> PathBuf {
    let dir = deps_dir()
        .parent()
        .unwrap()
        .join("rwg-c-plugins")
        .join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Compiles the C file `src` (relative to the repository root) into the
/// shared library `out_dir/lib<name>.so` with the given `-D` defines,
/// warnings as errors.
pub fn compile_c(src: &str, out_dir: &Path, name: &str, defines: &[&str]) -> PathBuf {
    compile_c_against(src, "rwg-env/include", out_dir, name, defines)
}

/// [`compile_c`] with `rwg_plugin.h` taken from `include` (relative to the
/// repository root), e.g. the ABI 1.0 header kept in `tests/data/abi-v1.0`.
pub fn compile_c_against(
    src: &str,
    include: &str,
    out_dir: &Path,
    name: &str,
    defines: &[&str],
) -> PathBuf {
    let root = repo_root();
    let out = out_dir.join(library_file_name(name));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let mut cmd = Command::new(&cc);
    cmd.args([
        "-std=c11",
        "-O1",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-pedantic",
    ])
    .args(["-shared", "-fPIC", "-fvisibility=hidden"])
    .arg("-I")
    .arg(root.join(include))
    .args(defines.iter().map(|d| format!("-D{d}")))
    .arg(root.join(src))
    .arg("-o")
    .arg(&out);
    let res = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler '{cc}': {e}"));
    assert!(
        res.status.success(),
        "{cmd:?} failed:\n{}",
        String::from_utf8_lossy(&res.stderr)
    );
    out
}
