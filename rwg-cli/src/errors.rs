//! The hint under an error: when a file was not found, a "did you mean"
//! for a path on the command line that does not exist but nearly matches
//! one that does; when a directory could not be created, the path on the
//! command line that is a file.

use std::path::{Path, PathBuf};

/// Whether some cause of `e` is an I/O error of `kind`.
fn io_kind(e: &anyhow::Error, kind: std::io::ErrorKind) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == kind)
    })
}

/// Whether some cause of `e` is a "not found" I/O error.
fn not_found(e: &anyhow::Error) -> bool {
    io_kind(e, std::io::ErrorKind::NotFound)
}

/// For an "already exists" error (a directory to create where a file is):
/// the command-line arguments the error names that are files.
fn file_not_directory(e: &anyhow::Error, args: &[String]) -> Option<String> {
    if !io_kind(e, std::io::ErrorKind::AlreadyExists) {
        return None;
    }
    let text = format!("{e:#}");
    let hints: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with('-') && text.contains(a.as_str()))
        .map(Path::new)
        .filter(|p| p.exists() && !p.is_dir())
        .map(|p| {
            format!(
                "{} is a file, not a directory: name a directory (or a path that does not \
                 exist yet)",
                p.display()
            )
        })
        .collect();
    (!hints.is_empty()).then(|| hints.join("\n"))
}

/// The type of getrlimit's resource argument.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
type Resource = libc::__rlimit_resource_t;
#[cfg(all(unix, not(all(target_os = "linux", target_env = "gnu"))))]
type Resource = libc::c_int;

/// This process's soft limit of `resource`, unless unlimited (or unknown).
#[cfg(unix)]
fn soft_limit(resource: Resource) -> Option<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit fills a valid struct.
    let ok = unsafe { libc::getrlimit(resource, &mut lim) } == 0;
    (ok && lim.rlim_cur != libc::RLIM_INFINITY).then_some(lim.rlim_cur)
}

/// For a write past the largest file this process may write: the limit,
/// and what to do.
fn file_size_limit() -> String {
    #[cfg(unix)]
    if let Some(cur) = soft_limit(libc::RLIMIT_FSIZE) {
        return format!(
            "files are limited to {} bytes in this shell (`ulimit -f` shows the limit in \
             blocks of 1024 bytes): raise it (`ulimit -f unlimited`) and run the same \
             command again; what was committed is kept",
            cur
        );
    }
    "the file system or a quota refuses a file this large".into()
}

/// Whether `e` is an open-file limit's refusal (EMFILE: this process's
/// `ulimit -n`; ENFILE: the system's), as an I/O error or in a message that
/// quotes one (a worker that could not start).
fn too_many_open_files(e: &anyhow::Error) -> bool {
    #[cfg(unix)]
    {
        let raw = e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| matches!(io.raw_os_error(), Some(libc::EMFILE | libc::ENFILE)))
        });
        let text = format!("{e:#}");
        raw || text.contains(&format!("(os error {})", libc::EMFILE))
            || text.contains(&format!("(os error {})", libc::ENFILE))
    }
    #[cfg(not(unix))]
    {
        let _ = e;
        false
    }
}

/// For an open-file limit's refusal: the limit, and what to do.
fn open_files_limit() -> String {
    #[cfg(unix)]
    if let Some(cur) = soft_limit(libc::RLIMIT_NOFILE) {
        return format!(
            "a process may have {} files open at once here (`ulimit -n`; each worker \
             takes a few for its pipes): raise it (`ulimit -n 4096`, at most `ulimit -Hn`) \
             and run the same command again; what was committed is kept",
            cur
        );
    }
    "the system's open-file table is full (`/proc/sys/fs/file-nr`): close some programs and \
     run the same command again; what was committed is kept"
        .into()
}

/// The existing entry of `missing`'s folder whose name is nearest to
/// `missing`'s, if one is close enough to be a typo.
pub fn nearby(missing: &Path) -> Option<PathBuf> {
    let name = missing.file_name()?.to_str()?;
    let parent = match missing.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // a misspelt folder: correct it first
    let parent = if parent.is_dir() {
        parent
    } else {
        nearby(&parent).filter(|p| p.is_dir())?
    };
    let missing = parent.join(name);
    let names: Vec<String> = std::fs::read_dir(&parent)
        .ok()?
        .flatten()
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    let best = rwg_env::suggest::nearest(name, names.iter().map(String::as_str))?;
    let found = missing.with_file_name(best);
    // keep the path relative as given: no "./" the user did not type
    Some(match found.strip_prefix(".") {
        Ok(rel) if !rel.as_os_str().is_empty() => rel.to_path_buf(),
        _ => found,
    })
}

/// A hint for a "not found" error: the command-line arguments that name a
/// missing file the error is about, each with the nearest existing one.
/// Only arguments the error names: an output path that does not exist yet
/// (`--out runs/mine`) is no typo, and "did you mean runs/quick?" for it
/// would mislead.
pub fn hint(e: &anyhow::Error, args: &[String]) -> Option<String> {
    if let Some(h) = file_not_directory(e, args) {
        return Some(h);
    }
    if io_kind(e, std::io::ErrorKind::FileTooLarge) {
        return Some(file_size_limit());
    }
    if too_many_open_files(e) {
        return Some(open_files_limit());
    }
    if !not_found(e) {
        return None;
    }
    let text = format!("{e:#}");
    let hints: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with('-') && (a.contains('/') || a.contains('.')))
        .filter(|a| text.contains(a.as_str()))
        .map(Path::new)
        .filter(|p| !p.exists())
        .filter_map(|p| {
            nearby(p).map(|n| {
                format!(
                    "{} does not exist; did you mean {}?",
                    p.display(),
                    n.display()
                )
            })
        })
        .collect();
    (!hints.is_empty()).then(|| hints.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_for_not_found() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        assert!(not_found(&anyhow::Error::new(io).context("cannot read x")));
        let io = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "no");
        assert!(!not_found(&anyhow::Error::new(io)));
    }

    #[test]
    fn only_for_the_paths_the_error_names() {
        let dir = std::env::temp_dir().join(format!("rwg-hint-named-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("quick")).unwrap();
        std::fs::write(dir.join("quick.toml"), "").unwrap();
        let (typo, out) = (dir.join("qick.toml"), dir.join("quik"));
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        let e = anyhow::Error::new(io).context(format!("cannot read {}", typo.display()));
        let args = [
            typo.display().to_string(),
            "--out".into(),
            out.display().to_string(),
        ];
        let h = hint(&e, &args).unwrap();
        assert!(
            h.contains("did you mean") && h.contains("quick.toml"),
            "{h}"
        );
        assert!(!h.contains(&out.display().to_string()), "{h}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_where_a_directory_is_created() {
        let dir = std::env::temp_dir().join(format!("rwg-hint-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("out");
        std::fs::write(&file, "").unwrap();
        let io = std::io::Error::new(std::io::ErrorKind::AlreadyExists, "File exists");
        let e = anyhow::Error::new(io).context(format!("cannot create {}", file.display()));
        let args = [file.display().to_string(), dir.display().to_string()];
        assert_eq!(
            hint(&e, &args).unwrap(),
            format!(
                "{} is a file, not a directory: name a directory (or a path that does not \
                 exist yet)",
                file.display()
            )
        );
        std::fs::remove_file(&file).unwrap();
        assert_eq!(hint(&e, &args), None);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn did_you_mean_a_nearby_file() {
        let dir = std::env::temp_dir().join(format!("rwg-hint-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("quick.toml"), "").unwrap();
        let missing = dir.join("qick.toml");
        assert_eq!(nearby(&missing), Some(dir.join("quick.toml")));
        assert_eq!(nearby(&dir.join("completely-else.json")), None);
        std::fs::create_dir_all(dir.join("examples")).unwrap();
        std::fs::write(dir.join("examples/actions.txt"), "").unwrap();
        assert_eq!(
            nearby(&dir.join("exampels/actions.txt")),
            Some(dir.join("examples/actions.txt"))
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
