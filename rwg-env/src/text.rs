//! Text from outside rwg (a plugin's error message, a worker's stderr) made
//! safe to print: control characters shown escaped, so that a terminal
//! escape sequence in it cannot recolour, retitle or clear the user's
//! terminal; and what rwg says when the system refuses it a thread.

use std::borrow::Cow;

/// `text` with every control character other than newline and tab written
/// as an escape: `\x1b` for the C0 controls and DEL, `\u{9b}` for the C1
/// controls, `\r` for a carriage return. Borrowed when there is none.
pub fn escape_controls(text: &str) -> Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        match c {
            '\r' => out.push_str("\\r"),
            c if needs_escape(c) && (c as u32) < 0x80 => {
                out.push_str(&format!("\\x{:02x}", c as u32));
            }
            c if needs_escape(c) => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

/// What to do when a thread cannot start (follows its error).
pub const THREAD_LIMIT_ADVICE: &str = "rwg's process is at a limit on memory or threads \
     (`ulimit -v`, `ulimit -u`, a container's or job's limits): raise the limit, or run with \
     fewer --threads";

fn needs_escape(c: char) -> bool {
    c.is_control() && c != '\n' && c != '\t'
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_sequences_are_shown_not_obeyed() {
        assert!(matches!(escape_controls("plain\ttext\n"), Cow::Borrowed(_)));
        assert_eq!(
            escape_controls("\x1b[31mred\x1b]0;title\x07 \r\u{9b}2J"),
            "\\x1b[31mred\\x1b]0;title\\x07 \\r\\u{9b}2J"
        );
    }
}
