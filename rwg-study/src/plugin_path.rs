//! What a manifest's `plugin = "..."` must name, and what rwg says at the
//! manifest line when it does not: an empty value, a path that does not
//! exist, a directory, or something that is not a regular file.

use std::path::Path;

/// Checks the raw text of `plugin = "..."` (key `key`, e.g. `envs[0]`):
/// an empty value would name the manifest's own folder.
pub fn check_value(key: &str, raw: &str) -> Result<(), String> {
    if raw.trim().is_empty() {
        return Err(format!(
            "{key}.plugin is empty: name the plugin library file (a path relative to the \
             manifest's folder, or absolute), or remove `plugin` to use a built-in env or one \
             found on RWG_PLUGIN_PATH"
        ));
    }
    Ok(())
}

/// Checks that `path` (the resolved value of `key`'s `plugin`) is a plugin
/// library file: the message says what it is instead.
pub fn check_file(key: &str, path: &Path) -> Result<(), String> {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(format!("{key}.plugin: no such file: {}", path.display()))
        }
        Err(e) => return Err(format!("{key}.plugin: cannot read {}: {e}", path.display())),
    };
    if meta.is_dir() {
        let found = rwg_plugin_host::find_plugin_files(path.as_os_str()).files;
        let inside = match found.len() {
            0 => format!("it holds no .{} file", std::env::consts::DLL_EXTENSION),
            _ => {
                let names: Vec<String> = found
                    .iter()
                    .take(5)
                    .map(|f| f.display().to_string())
                    .collect();
                format!("in it: {}", names.join(", "))
            }
        };
        return Err(format!(
            "{key}.plugin: {} is a directory, not a plugin library: name the library file \
             itself ({inside}); to search a folder for plugins, set RWG_PLUGIN_PATH to it and \
             remove `plugin`",
            path.display()
        ));
    }
    if !meta.is_file() {
        return Err(format!(
            "{key}.plugin: {} is not a regular file (a plugin is a shared library file)",
            path.display()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_missing_and_folder_values_say_what_they_are() {
        assert!(check_value("envs[0]", "").unwrap_err().contains("is empty"));
        assert!(check_value("envs[0]", "lib.so").is_ok());
        let dir = std::env::temp_dir().join(format!("rwg-plugin-path-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let e = check_file("envs[1]", &dir).unwrap_err();
        assert!(e.starts_with("envs[1].plugin: "), "{e}");
        assert!(e.contains("is a directory, not a plugin library"), "{e}");
        assert!(e.contains("holds no"), "{e}");
        let e = check_file("envs[1]", &dir.join("nope.so")).unwrap_err();
        assert!(e.contains("no such file"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
