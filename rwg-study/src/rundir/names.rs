//! Cell directory names: the one mapping from (environment id, architecture
//! name, bias) to the name of a cell's directory under `cells/`.
//!
//! The mapping is injective and every name it gives is a valid, portable
//! file name that stays inside `cells/` on Linux, macOS and Windows:
//!
//! - A **plain** cell keeps its readable name `<env>__<arch>__<bias|nobias>`
//!   (so the names of existing runs do not change), with `/` written as `+`
//!   and `:` as `=` (plugin ids `acme/Maze-v2`, Gymnasium ids
//!   `gymnasium:ALE/Pong-v5`; neither `+` nor `=` appears in a plain part
//!   otherwise, so this is one-to-one). A cell is plain when the env id and
//!   the architecture name are non-empty, use only ASCII letters, digits, `-`,
//!   `_`, `.`, `/` and `:`, hold no `__`, neither starts nor ends with `_`
//!   (so the two `__` separators can be found again: the name decodes to one
//!   tuple only), the name is at most [`MAX_PLAIN_LEN`] bytes, and its part
//!   before the first `.` is not a reserved Windows device name (`CON`,
//!   `NUL`, `COM1`, ...).
//! - Any other cell gets `<readable>~<hash>`: the readable part with every
//!   character outside `[A-Za-z0-9-_]` replaced by `_` (so no `.`, no
//!   trailing dot or space, no reserved stem), cut to 64 bytes per part, then
//!   `~` (which no plain name contains) and the first 16 hex digits of the
//!   SHA-256 of the tuple's unambiguous encoding. `a/b` and `a_b` therefore
//!   get different directories, and so do `adv/Ok-v0` and `adv_Ok-v0`.
//!
//! What a name function alone cannot rule out is two names that differ only
//! in letter case (`0HL` and `0hl`), which share a directory on macOS and
//! Windows, and (with negligible odds) a 64-bit hash collision:
//! [`check_distinct`] finds both when the cells are planned, and the manifest
//! is refused naming both entries.

use sha2::{Digest, Sha256};

/// Longest plain cell name kept as is (bytes). File systems allow 255 bytes
/// per name; figures are written as `<cell>.<kind>.<ext>` next to it.
pub const MAX_PLAIN_LEN: usize = 200;

/// Longest part of a hashed name taken from each of env id and architecture.
const HASHED_PART_LEN: usize = 64;

/// Windows device names (case-insensitive, with or without an extension).
const RESERVED: [&str; 24] = [
    "CON", "PRN", "AUX", "NUL", "COM0", "COM1", "COM2", "COM3", "COM4", "COM5", "COM6", "COM7",
    "COM8", "COM9", "LPT0", "LPT1", "LPT2", "LPT3", "LPT4", "LPT5", "LPT6", "LPT7", "LPT8", "LPT9",
];

fn bias_word(bias: bool) -> &'static str {
    if bias {
        "bias"
    } else {
        "nobias"
    }
}

/// Whether a part (env id or architecture name) may appear as is.
fn plain_part(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|c| c.is_ascii_alphanumeric() || b"-_./:".contains(&c))
        && !s.contains("__")
        && !s.starts_with('_')
        && !s.ends_with('_')
}

/// Whether the part of `name` before its first `.` is a Windows device name.
fn reserved_stem(name: &str) -> bool {
    let stem = name.split('.').next().unwrap_or(name).trim_end();
    RESERVED.iter().any(|r| r.eq_ignore_ascii_case(stem))
}

/// `s` with characters outside `[A-Za-z0-9-_]` replaced by `_`, at most
/// `max` bytes.
fn readable(s: &str, max: usize) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .take(max)
        .collect()
}

/// The directory name of a cell under `cells/` (see the module docs).
pub fn cell_dir_name(env: &str, arch: &str, bias: bool) -> String {
    let esc = |s: &str| s.replace('/', "+").replace(':', "=");
    let plain = format!("{}__{}__{}", esc(env), esc(arch), bias_word(bias));
    if plain_part(env) && plain_part(arch) && plain.len() <= MAX_PLAIN_LEN && !reserved_stem(&plain)
    {
        return plain;
    }
    // Length-prefixed, so no two tuples encode alike.
    let mut h = Sha256::new();
    for part in [env, arch] {
        h.update((part.len() as u64).to_le_bytes());
        h.update(part.as_bytes());
    }
    h.update([u8::from(bias)]);
    let digest = h.finalize();
    let hex: String = digest[..8].iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{}__{}__{}~{hex}",
        readable(env, HASHED_PART_LEN),
        readable(arch, HASHED_PART_LEN),
        bias_word(bias)
    )
}

/// Finds the first two of `names` that would share a directory on some file
/// system (equal, or equal up to ASCII letter case); returns their indices.
pub fn check_distinct<S: AsRef<str>>(names: &[S]) -> Option<(usize, usize)> {
    let mut seen = std::collections::HashMap::new();
    for (i, n) in names.iter().enumerate() {
        if let Some(&j) = seen.get(&n.as_ref().to_ascii_lowercase()) {
            return Some((j, i));
        }
        seen.insert(n.as_ref().to_ascii_lowercase(), i);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A name every file system accepts inside `cells/`.
    fn portable(n: &str) {
        assert!(!n.is_empty() && n.len() <= 255, "{n}");
        assert!(
            !n.contains(['/', '\\', ':', '*', '?', '"', '<', '>', '|', '\0']),
            "{n}"
        );
        assert!(!n.ends_with(['.', ' ']), "{n}");
        assert!(n != "." && n != "..", "{n}");
        assert!(!reserved_stem(n), "{n}");
        assert!(n.is_ascii(), "{n}");
    }

    #[test]
    fn existing_names_do_not_change() {
        for (env, arch, bias, want) in [
            ("CartPole-v0", "0HL", false, "CartPole-v0__0HL__nobias"),
            ("Acrobot-v1", "1HL-4", true, "Acrobot-v1__1HL-4__bias"),
            (
                "MountainCarContinuous-v0",
                "2HL-4-4",
                false,
                "MountainCarContinuous-v0__2HL-4-4__nobias",
            ),
            ("Pendulum-v0", "2HL-4-4", true, "Pendulum-v0__2HL-4-4__bias"),
            (
                "classic_control/CartPole-v1",
                "0HL",
                false,
                "classic_control+CartPole-v1__0HL__nobias",
            ),
            (
                "gymnasium:ALE/Pong-v5",
                "0HL",
                true,
                "gymnasium=ALE+Pong-v5__0HL__bias",
            ),
        ] {
            assert_eq!(cell_dir_name(env, arch, bias), want);
        }
        assert!(cell_dir_name("a+b", "0HL", false).contains('~'));
    }

    #[test]
    fn names_that_sanitise_alike_stay_apart() {
        let pairs = [
            (("CartPole-v0", "a/b"), ("CartPole-v0", "a_b")),
            (("adv/Ok-v0", "0HL"), ("adv_Ok-v0", "0HL")),
            (("a__b", "c"), ("a", "b__c")),
            (("a_", "b"), ("a", "_b")),
            (("x", "2HL 4,4"), ("x", "2HL_4_4")),
            (
                ("gymnasium:ALE/Pong-v5", "0HL"),
                ("gymnasium_ALE_Pong-v5", "0HL"),
            ),
        ];
        for ((e1, a1), (e2, a2)) in pairs {
            let (n1, n2) = (cell_dir_name(e1, a1, false), cell_dir_name(e2, a2, false));
            assert_ne!(
                n1.to_lowercase(),
                n2.to_lowercase(),
                "{e1} {a1} / {e2} {a2}"
            );
            portable(&n1);
            portable(&n2);
        }
        assert_ne!(
            cell_dir_name("x", "a/b", true),
            cell_dir_name("x", "a/b", false)
        );
    }

    #[test]
    fn any_id_maps_to_a_portable_name() {
        let long = "L".repeat(5000);
        for (env, arch) in [
            ("gymnasium:ALE/Pong-v5", "0HL"),
            ("CON", "0HL"),
            ("con.x", "0HL"),
            ("NUL", "x"),
            ("lpt1", "y"),
            ("..", ".."),
            ("env.", "arch "),
            ("a\\b", "c*d?e\"f<g>h|i"),
            ("ünïcödé", "日本"),
            ("", ""),
            (long.as_str(), long.as_str()),
            ("x\0y", "\n"),
        ] {
            portable(&cell_dir_name(env, arch, false));
        }
        // Windows would treat these as devices: they are hashed.
        assert!(cell_dir_name("CON.x", "0HL", false).contains('~'));
        assert!(cell_dir_name("aux.1", "0HL", false).contains('~'));
        assert_eq!(cell_dir_name("aux", "0HL", false), "aux__0HL__nobias");
        // Not devices: kept.
        assert_eq!(
            cell_dir_name("CONSOLE", "0HL", false),
            "CONSOLE__0HL__nobias"
        );
    }

    #[test]
    fn case_only_differences_are_found() {
        let names = [
            cell_dir_name("CartPole-v0", "0HL", false),
            cell_dir_name("CartPole-v0", "1HL", false),
            cell_dir_name("CartPole-v0", "0hl", false),
        ];
        assert_eq!(check_distinct(&names), Some((0, 2)));
        assert_eq!(check_distinct(&names[..2]), None);
    }
}
