//! Quoting for the `rwg ...` commands rwg prints (hints, resume lines,
//! `rwg top`'s replay column, Slurm scripts): every word that is a path or a
//! name from a manifest goes through [`sh_quote`] or [`sh_path`], so a
//! command pasted into a POSIX shell runs as printed, whatever spaces,
//! quotes or `$` the path or name holds.

use std::path::Path;

/// `s` quoted for a POSIX shell: unchanged when every character is safe
/// unquoted (ASCII letters and digits and `-_./=:,+@%`), else in single
/// quotes, with each `'` written `'\''`. The empty string is `''`.
pub fn sh_quote(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// A path quoted for a POSIX shell, as a command's argument ([`sh_quote`]
/// of its text): a relative path starting with `-` is written `./-...`, so
/// that no command parses it as an option. A name that is not UTF-8 keeps
/// its bytes: each byte that is not UTF-8 is written `"$(printf '\NNN')"`
/// (POSIX), so the command still names that path.
pub fn sh_path(p: &Path) -> String {
    let bytes = p.as_os_str().as_encoded_bytes();
    let dash = if bytes.starts_with(b"-") { "./" } else { "" };
    match std::str::from_utf8(bytes) {
        Ok(s) => sh_quote(&format!("{dash}{s}")),
        Err(_) => {
            let mut out = dash.to_string();
            for chunk in bytes.utf8_chunks() {
                if !chunk.valid().is_empty() {
                    out.push_str(&sh_quote(chunk.valid()));
                }
                for b in chunk.invalid() {
                    out.push_str(&format!("\"$(printf '\\{b:03o}')\""));
                }
            }
            out
        }
    }
}

/// `cmd` run with `PYTHONPATH` set to `pythonpath` (quoted), when there is
/// one: what a printed command that starts a Python env needs.
pub fn with_pythonpath(pythonpath: Option<&str>, cmd: String) -> String {
    match pythonpath {
        Some(p) if !p.is_empty() => format!("PYTHONPATH={} {cmd}", sh_quote(p)),
        _ => cmd,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shell_quoting() {
        assert_eq!(sh_quote("runs/a-1"), "runs/a-1");
        assert_eq!(sh_quote("a b"), "'a b'");
        assert_eq!(sh_quote("it's"), r"'it'\''s'");
        assert_eq!(sh_quote(""), "''");
        assert_eq!(sh_quote("$HOME"), "'$HOME'");
        assert_eq!(sh_path(Path::new("my run/m.toml")), "'my run/m.toml'");
        assert_eq!(sh_path(Path::new("-run d")), "'./-run d'");
        assert_eq!(sh_path(Path::new("-x/manifest.toml")), "./-x/manifest.toml");
        assert_eq!(sh_path(Path::new("/tmp/-x")), "/tmp/-x");
    }

    #[test]
    fn a_path_that_is_not_utf8_reads_back_through_a_shell() {
        use std::os::unix::ffi::OsStrExt;
        let raw: &[u8] = b"-a b\xff/c'\xfe\n";
        let quoted = sh_path(Path::new(std::ffi::OsStr::from_bytes(raw)));
        let out = std::process::Command::new("sh")
            .args(["-c", &format!("printf %s {quoted}")])
            .output();
        if let Ok(out) = out {
            assert_eq!(out.stdout, [b"./", raw].concat(), "{quoted}");
        }
    }

    #[test]
    fn a_quoted_word_reads_back_through_a_shell() {
        let word = "a b'c\"$d`e\\f\ng";
        let out = std::process::Command::new("sh")
            .args(["-c", &format!("printf %s {}", sh_quote(word))])
            .output();
        if let Ok(out) = out {
            assert_eq!(String::from_utf8_lossy(&out.stdout), word);
        }
    }
}
