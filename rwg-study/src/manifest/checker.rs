//! Errors located in the manifest's text, and the range and length checks
//! every section of the manifest shares.

use super::ManifestError;
use crate::limits::{in_range, short_enough};
use crate::manifest_text::line_col;
use std::ops::Range;
use toml::Spanned;

/// An error at `span` of `text`, the text of manifest `file`.
pub(super) fn locate(file: &str, text: &str, span: Range<usize>, message: String) -> ManifestError {
    let (line, column) = line_col(text, span.start);
    ManifestError {
        file: file.to_string(),
        line,
        column,
        message,
    }
}

/// The manifest being checked: makes its errors, located in its text.
pub(super) struct Checker<'a> {
    /// The manifest's file name.
    pub(super) file: &'a str,
    /// The manifest's text.
    pub(super) text: &'a str,
}

impl Checker<'_> {
    /// An error at `span`.
    pub(super) fn err(&self, span: Range<usize>, message: String) -> ManifestError {
        locate(self.file, self.text, span, message)
    }

    /// An error from a check that states where and what: `(span, message)`.
    pub(super) fn located(&self, (span, message): (Range<usize>, String)) -> ManifestError {
        self.err(span, message)
    }

    /// A count in `min..=max`, else an error stating the limit.
    pub(super) fn count(
        &self,
        v: &Spanned<i64>,
        key: &str,
        min: i64,
        max: u64,
    ) -> Result<u64, ManifestError> {
        in_range(
            key,
            *v.get_ref(),
            min,
            i64::try_from(max).unwrap_or(i64::MAX),
        )
        .map(|v| v as u64)
        .map_err(|m| self.err(v.span(), m))
    }

    /// A string of at most `max` bytes, else an error stating the limit.
    pub(super) fn short(
        &self,
        v: &Spanned<String>,
        key: &str,
        max: usize,
    ) -> Result<(), ManifestError> {
        short_enough(key, v.get_ref(), max).map_err(|m| self.err(v.span(), m))
    }

    /// The entries of section `section`: at least one (`needs` says what),
    /// at most `max` (rwg's limit; the error stands at the first entry
    /// beyond it, located by `span_of`).
    pub(super) fn entry_count<T>(
        &self,
        list: &Spanned<Vec<T>>,
        section: &str,
        needs: &str,
        max: usize,
        span_of: impl Fn(&T) -> Range<usize>,
    ) -> Result<(), ManifestError> {
        let entries = list.get_ref();
        if entries.is_empty() {
            return Err(self.err(list.span(), format!("{section}: needs at least {needs}")));
        }
        if entries.len() > max {
            return Err(self.err(
                span_of(&entries[max]),
                format!(
                    "{section}: at most {max} (rwg's limit), got {}",
                    entries.len()
                ),
            ));
        }
        Ok(())
    }
}
