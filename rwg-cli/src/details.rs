//! An error's long part (a Python traceback, the end of a worker's stderr)
//! kept in a file that the message names, so that every message that ends
//! rwg stays one `error:` line: `... (Python python3); the Python traceback
//! is in runs/x/last-error.txt`. The file holds the whole message, after
//! the command line that met it.

// A failed `rwg run` keeps it in its run directory (the next failure
// replaces it).
use rwg_study::rundir::LAST_ERROR as RUN_FILE;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `text`, whose long part (if any, [`rwg_worker::split_details`]) is
/// written to a file in `run_dir` (a run directory that exists), else in
/// the temporary folder, and named instead. If no file can be written, the
/// whole text, so that nothing is lost.
pub fn one_line(text: &str, run_dir: Option<&Path>) -> String {
    let Some((head, what, long)) = rwg_worker::split_details(text) else {
        return text.to_string();
    };
    if let Some(line) = short(head, what, long) {
        return line;
    }
    let path = match run_dir.filter(|d| d.is_dir()) {
        Some(d) => d.join(RUN_FILE),
        None => std::env::temp_dir().join(format!("rwg-error-{}.txt", std::process::id())),
    };
    match keep(&path, &format!("error: {text}")) {
        Ok(()) => format!("{head}; {what} is in {}", path.display()),
        Err(_) => text.to_string(),
    }
}

/// The long parts of several messages (the checks of `rwg check`) kept in
/// one file of the temporary folder, which each shortened message names.
pub struct KeptFile {
    path: PathBuf,
    texts: String,
}

impl KeptFile {
    /// A file named for `what` (`rwg-check-PID.txt`), written when a
    /// message has a long part.
    pub fn new(what: &str) -> KeptFile {
        KeptFile {
            path: std::env::temp_dir().join(format!("rwg-{what}-{}.txt", std::process::id())),
            texts: String::new(),
        }
    }

    /// `text` with its long part named instead, the whole text added to the
    /// file; the whole text if it has no long part or the file cannot be
    /// written.
    pub fn one_line(&mut self, text: &str) -> String {
        let Some((head, what, long)) = rwg_worker::split_details(text) else {
            return text.to_string();
        };
        if let Some(line) = short(head, what, long) {
            return line;
        }
        self.texts.push_str(text);
        self.texts.push_str("\n\n");
        match keep(&self.path, self.texts.trim_end()) {
            Ok(()) => format!("{head}; {what} is in {}", self.path.display()),
            Err(_) => text.to_string(),
        }
    }
}

/// The longest long part printed on the message's line: one line of a
/// worker's stderr (`rwg: the interpreter ... is a shell`) says more where
/// it is read than in a file.
const SHORT: usize = 300;

/// `head; what: LINE` when the long part (its label, then its text) is one
/// line of at most [`SHORT`] characters.
fn short(head: &str, what: &str, long: &str) -> Option<String> {
    let (_, rest) = long.split_once('\n')?;
    let rest = rest.trim();
    (!rest.is_empty() && !rest.contains('\n') && rest.chars().count() <= SHORT)
        .then(|| format!("{head}; {what}: {rest}"))
}

/// Writes the command line and `text` to `path` (replacing it; readable
/// by its owner only, as a traceback may show paths and values).
fn keep(path: &PathBuf, text: &str) -> std::io::Result<()> {
    let _ = std::fs::remove_file(path);
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut f = options.open(path)?;
    let args: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    writeln!(
        f,
        "{} (rwg {}):\n{text}",
        args.join(" "),
        env!("CARGO_PKG_VERSION")
    )?;
    f.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_long_part_goes_to_a_file_the_line_names() {
        let dir = std::env::temp_dir().join(format!("rwg-details-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = "env failed (Python p)\nPython traceback:\nTraceback\n  File x";
        let line = one_line(text, Some(&dir));
        let file = dir.join(RUN_FILE);
        assert_eq!(
            line,
            format!(
                "env failed (Python p); the Python traceback is in {}",
                file.display()
            )
        );
        let kept = std::fs::read_to_string(&file).unwrap();
        assert!(kept.ends_with(&format!("error: {text}\n")), "{kept}");
        assert_eq!(one_line("short", Some(&dir)), "short");
        // a long part of one short line stays on the line
        let one = "the worker exited with status 97; the end of its stderr:\nrwg: a shell\n";
        assert_eq!(
            one_line(one, Some(&dir)),
            "the worker exited with status 97; the end of the worker's stderr: rwg: a shell"
        );
        // no run directory: the temporary folder
        let line = one_line(text, Some(&dir.join("missing")));
        assert!(
            line.contains(&std::env::temp_dir().display().to_string()),
            "{line}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
