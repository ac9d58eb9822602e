//! Turning a manifest file's bytes into text, and serde's type errors into
//! messages that name the key: `envs[2].episodes: expected an integer, found
//! the string "0"`.

use std::ops::Range;

/// Why a manifest's bytes are not UTF-8 TOML text: the byte offset where the
/// problem is, and what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct NotText {
    /// Byte offset of the problem in the file.
    pub offset: usize,
    /// What is wrong, ending in what the manifest must be.
    pub message: String,
}

/// What every message of [`decode`] ends with.
pub const MUST_BE_UTF8: &str = "the manifest must be UTF-8 TOML";

/// The manifest's text: UTF-8 (a leading UTF-8 byte-order mark is dropped),
/// without NUL bytes. UTF-16 (with or without a byte-order mark) and binary
/// files are refused with the offset of the first offending byte.
pub fn decode(bytes: &[u8]) -> Result<&str, NotText> {
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(NotText {
            offset: 0,
            message: format!(
                "the file starts with a UTF-16 byte-order mark; {MUST_BE_UTF8} \
                 (convert it, e.g. with `iconv -f UTF-16 -t UTF-8`)"
            ),
        });
    }
    let bytes = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(bytes);
    let text = std::str::from_utf8(bytes).map_err(|e| NotText {
        offset: e.valid_up_to(),
        message: format!(
            "byte 0x{:02X} is not UTF-8; {MUST_BE_UTF8}",
            bytes[e.valid_up_to()]
        ),
    })?;
    check_no_nul(text)?;
    Ok(text)
}

/// Refuses text holding a NUL byte (binary data, or UTF-16 without a
/// byte-order mark).
pub fn check_no_nul(text: &str) -> Result<(), NotText> {
    match text.find('\0') {
        None => Ok(()),
        Some(offset) => Err(NotText {
            offset,
            message: format!("a NUL byte (binary data, or UTF-16 text); {MUST_BE_UTF8}"),
        }),
    }
}

/// 1-based line and column (in characters) of byte `offset` of `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |p| p + 1);
    (line, before[line_start..].chars().count() + 1)
}

/// Deserializes `text` as `T`, turning a failure into (byte span, message)
/// where the message starts with the key path (`envs[2].episodes: ...`) and
/// says in plain words what was expected and found.
pub fn from_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, (Range<usize>, String)> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = key_path(e.path());
        let inner = e.into_inner();
        let span = inner.span().unwrap_or(0..0);
        // TOML's own errors (a value it cannot read) come without a path
        let path = match path.is_empty() {
            true => key_at(text, span.start).unwrap_or_default(),
            false => path,
        };
        let message = plain_message(inner.message().trim_end());
        let message = if path.is_empty() {
            message
        } else {
            format!("{path}: {message}")
        };
        (span, message)
    })
}

/// `envs[2].episodes`: the path without the private fields of
/// `toml::Spanned`.
fn key_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } if key.starts_with("$__") => {}
            Segment::Map { key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Enum { .. } | Segment::Unknown => {}
        }
    }
    out
}

/// The key path (`seed`, `envs[1].max_episode_steps`, `weights.scale`) of
/// the value starting at byte `offset` of `text`: the key before the `=`
/// on its line, under the last table header above it. `None` if no value
/// of a `key = value` line starts there.
pub fn key_at(text: &str, offset: usize) -> Option<String> {
    let offset = (0..=offset.min(text.len()))
        .rev()
        .find(|&o| text.is_char_boundary(o))?;
    let line_start = text[..offset].rfind('\n').map_or(0, |p| p + 1);
    let (left, between) = text[line_start..offset].rsplit_once('=')?;
    if !between.trim().is_empty() {
        return None;
    }
    // the last key of the line: after an inline table's `{` or `,`
    let key = left
        .rsplit(['{', ','])
        .next()
        .unwrap_or(left)
        .trim()
        .trim_matches('"');
    let bare = |c: char| c.is_ascii_alphanumeric() || "_-.".contains(c);
    if key.is_empty() || !key.chars().all(bare) {
        return None;
    }
    // the table it is in: the last header above, `[[envs]]` counted
    let mut table = String::new();
    let mut counts: std::collections::HashMap<&str, usize> = Default::default();
    for l in text[..line_start].lines().map(str::trim) {
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.split_once("]]")) {
            let n = counts.entry(name.0.trim()).or_insert(0);
            table = format!("{}[{}]", name.0.trim(), *n);
            *n += 1;
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.split_once(']')) {
            table = name.0.trim().to_string();
        }
    }
    Some(if table.is_empty() {
        key.to_string()
    } else {
        format!("{table}.{key}")
    })
}

/// serde's wording of a type (`i64`, `a sequence`, ...) as a manifest user
/// reads it.
fn plain_expected(expected: &str) -> String {
    match expected {
        "i64" | "u64" | "u32" | "i32" | "usize" => "an integer".into(),
        "f64" => "a number".into(),
        "a boolean" | "bool" => "true or false".into(),
        "a string" => "a string (in quotes)".into(),
        "a sequence" => "an array ([...])".into(),
        e if e.starts_with("struct ") || e == "a map" => "a table".into(),
        e => e.into(),
    }
}

/// serde's wording of a value (`string "0"`, `integer `5``) as "the string
/// \"0\"", "the integer 5".
fn plain_found(found: &str) -> String {
    let unquote = |s: &str| s.trim_matches('`').to_string();
    if let Some(s) = found.strip_prefix("string ") {
        format!("the string {s}")
    } else if let Some(s) = found.strip_prefix("integer ") {
        format!("the integer {}", unquote(s))
    } else if let Some(s) = found.strip_prefix("floating point ") {
        format!("the float {}", unquote(s))
    } else if let Some(s) = found.strip_prefix("boolean ") {
        unquote(s)
    } else if found == "sequence" {
        "an array".into()
    } else if found == "map" {
        "a table".into()
    } else {
        found.into()
    }
}

/// Rewrites serde's messages ("invalid type: string \"0\", expected i64",
/// "missing field `id`") in the manifest's terms.
fn plain_message(msg: &str) -> String {
    if let Some(rest) = msg.strip_prefix("invalid type: ") {
        if let Some((found, expected)) = rest.split_once(", expected ") {
            return format!(
                "expected {}, found {}",
                plain_expected(expected),
                plain_found(found)
            );
        }
    }
    if let Some(rest) = msg.strip_prefix("invalid value: ") {
        if let Some((found, expected)) = rest.split_once(", expected ") {
            return format!(
                "expected {}, found {}",
                plain_expected(expected),
                plain_found(found)
            );
        }
    }
    if msg.starts_with("number too large") || msg.starts_with("number too small") {
        return format!("{msg}: a TOML integer is from {} to {}", i64::MIN, i64::MAX);
    }
    if let Some(field) = msg.strip_prefix("missing field ") {
        return format!("missing key {field}");
    }
    if let Some(rest) = msg.strip_prefix("unknown field ") {
        return match rest.split_once(", expected ") {
            Some((field, keys)) => format!("unknown key {field}; the keys here are {keys}"),
            None => format!("unknown key {rest}"),
        };
    }
    msg.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf16_binary_and_bad_utf8_are_located() {
        let e = decode(&[0xFF, 0xFE, b's', 0]).unwrap_err();
        assert_eq!(e.offset, 0);
        assert!(
            e.message.contains("UTF-16 byte-order mark"),
            "{}",
            e.message
        );
        assert!(e.message.contains(MUST_BE_UTF8));
        let e = decode(b"seed = 1\nsam\xFFples = 2").unwrap_err();
        assert_eq!(e.offset, 12);
        assert_eq!(
            e.message,
            "byte 0xFF is not UTF-8; the manifest must be UTF-8 TOML"
        );
        // UTF-16LE without a byte-order mark: NUL bytes.
        let e = decode(b"s\0e\0e\0d\0").unwrap_err();
        assert_eq!(e.offset, 1);
        assert!(e.message.starts_with("a NUL byte"), "{}", e.message);
        assert_eq!(decode(b"\xEF\xBB\xBFseed = 1").unwrap(), "seed = 1");
    }

    #[test]
    fn line_col_counts_characters() {
        assert_eq!(line_col("a\nbé c", 5), (2, 3));
        assert_eq!(line_col("abc", 99), (1, 4));
    }

    #[test]
    fn keys_of_values_toml_cannot_read() {
        let text = "seed = 18446744073709551615\n[weights]\nscale = x\n\n\
                    [[envs]]\nid = \"a\"\n[[envs]]\nid = \"b\"\nmax_episode_steps = 1e\n\
                    kwargs = { a = 1, big = 99999999999999999999 }\n";
        let at = |s: &str| key_at(text, text.find(s).unwrap());
        assert_eq!(at("18446744073709551615").as_deref(), Some("seed"));
        assert_eq!(at("x\n").as_deref(), Some("weights.scale"));
        assert_eq!(at("1e\n").as_deref(), Some("envs[1].max_episode_steps"));
        assert_eq!(at("9999").as_deref(), Some("envs[1].big"));
        // not a value
        assert_eq!(at("seed"), None);
        assert_eq!(at("[weights]"), None);
        #[derive(serde::Deserialize, Debug)]
        struct Seed {
            #[expect(dead_code, reason = "read only to check that it parses")]
            seed: i64,
        }
        let (span, msg) = from_toml::<Seed>("seed = 18446744073709551615").unwrap_err();
        assert_eq!(span.start, 7);
        assert!(msg.starts_with("seed: number too large"), "{msg}");
        assert!(
            msg.ends_with("from -9223372036854775808 to 9223372036854775807"),
            "{msg}"
        );
    }

    #[test]
    fn messages_in_plain_words() {
        assert_eq!(
            plain_message("invalid type: string \"0\", expected i64"),
            "expected an integer, found the string \"0\""
        );
        assert_eq!(
            plain_message("invalid type: floating point `2.5`, expected i64"),
            "expected an integer, found the float 2.5"
        );
        assert_eq!(
            plain_message("invalid type: integer `3`, expected a sequence"),
            "expected an array ([...]), found the integer 3"
        );
        assert_eq!(plain_message("missing field `id`"), "missing key `id`");
        assert_eq!(
            plain_message("unknown field `x`, expected one of `a`, `b`"),
            "unknown key `x`; the keys here are one of `a`, `b`"
        );
    }
}
