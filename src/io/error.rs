//! The error type of the `io` module: every failure to read a UFF or CSV file
//! names the source (the file name the caller passed in), the place (line for
//! text, byte offset for binary data) and how to fix it.

use std::fmt;

/// Where in a source a problem is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// 1-based line number of a text record (UFF ASCII lines, CSV rows).
    Line(usize),
    /// 0-based byte offset into the file (UFF 58b binary data).
    Byte(usize),
    /// The whole file, no single place (e.g. "no FRF found").
    File,
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Place::Line(l) => write!(f, "line {l}"),
            Place::Byte(b) => write!(f, "byte offset {b}"),
            Place::File => Ok(()),
        }
    }
}

/// A source name plus a place in it, printed as `file.uff, line 12`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The name the caller gave for the bytes (usually the file name).
    pub source: String,
    pub place: Place,
}

impl Location {
    pub fn new(source: &str, place: Place) -> Self {
        Location {
            source: source.to_string(),
            place,
        }
    }
}

impl Location {
    /// Record `r` (1-based) of a UFF dataset whose record 1 is at `self`
    /// (the header records are one line each); a byte offset or the whole
    /// file stays as it is.
    pub fn record(&self, r: usize) -> Location {
        let place = match self.place {
            Place::Line(l) => Place::Line(l + r.saturating_sub(1)),
            other => other,
        };
        Location {
            source: self.source.clone(),
            place,
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.place {
            Place::File => write!(f, "{}", self.source),
            p => write!(f, "{}, {p}", self.source),
        }
    }
}

/// Errors reading or converting measurement files.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum IoError {
    /// The file ends before a record, data block or end delimiter is complete.
    #[error(
        "{at}: file ends early: {what}; the file is truncated or a header count is wrong, \
         re-export it from the test software"
    )]
    Truncated { at: Location, what: String },

    /// A record has more or fewer values or bytes than its header declares.
    #[error("{at}: wrong record length: {what}")]
    RecordLength { at: Location, what: String },

    /// A field that must hold a number does not.
    #[error("{at}: {field} is not a number: {text:?}; fix the value or the column layout")]
    NotNumeric {
        at: Location,
        field: String,
        text: String,
    },

    /// A value is NaN or infinite; measurement files must hold finite numbers.
    #[error("{at}: {field} is not finite ({value}); replace NaN/inf values before importing")]
    NonFinite {
        at: Location,
        field: String,
        value: f64,
    },

    /// A header field has a value this reader cannot use.
    #[error("{at}: {field} = {value} is not supported: {expected}")]
    InvalidField {
        at: Location,
        field: String,
        value: String,
        expected: String,
    },

    /// Two FRFs that must share one frequency axis do not.
    #[error(
        "{at}: FRF {channel} has a different frequency axis than the first FRF of \
         position {position} ({detail}); export all FRFs of one configuration on one grid"
    )]
    AxisMismatch {
        at: Location,
        channel: String,
        position: u32,
        detail: String,
    },

    /// The same response/reference pair appears twice in one position.
    #[error(
        "{at}: FRF {channel} appears twice in position {position}; remove the duplicate \
         or give the measurements different load case ids"
    )]
    DuplicateChannel {
        at: Location,
        channel: String,
        position: u32,
    },

    /// The file holds no FRF (UFF function type 4 / CSV `re:`/`im:` columns).
    #[error("{at}: no FRF found ({detail})")]
    NoFrf { at: Location, detail: String },

    /// Structural problem in a CSV table (missing column, bad header, ragged row).
    #[error("{at}: {what}")]
    Csv { at: Location, what: String },

    /// A measured value no measurement can have: a negative or
    /// non-increasing frequency line, a coherence outside [0, 1].
    #[error("{at}: {what}")]
    Implausible { at: Location, what: String },

    /// A count read from the file would need more memory than the limit
    /// (`--max-memory`); refused before anything is allocated.
    #[error(
        "{at}: {what} need an estimated {needed}, more than the memory limit of {limit}; \
         the count in the file is wrong, or raise the limit with --max-memory"
    )]
    OverLimit {
        at: Location,
        what: String,
        needed: String,
        limit: String,
    },

    /// A selection (DOF pattern, band) is malformed or selects nothing.
    #[error("invalid selection: {what}")]
    Selection { what: String },

    /// Data that cannot be expressed in the target format.
    #[error("cannot write {what}")]
    Unwritable { what: String },
}

impl IoError {
    pub(crate) fn truncated(source: &str, place: Place, what: impl Into<String>) -> Self {
        IoError::Truncated {
            at: Location::new(source, place),
            what: what.into(),
        }
    }

    pub(crate) fn record_length(source: &str, place: Place, what: impl Into<String>) -> Self {
        IoError::RecordLength {
            at: Location::new(source, place),
            what: what.into(),
        }
    }

    pub(crate) fn not_numeric(source: &str, place: Place, field: &str, text: &[u8]) -> Self {
        let mut text = String::from_utf8_lossy(text).into_owned();
        if text.len() > 40 {
            let cut = (0..=40)
                .rev()
                .find(|&i| text.is_char_boundary(i))
                .unwrap_or(0);
            text.truncate(cut);
        }
        IoError::NotNumeric {
            at: Location::new(source, place),
            field: field.to_string(),
            text,
        }
    }

    pub(crate) fn invalid(
        source: &str,
        place: Place,
        field: &str,
        value: impl fmt::Display,
        expected: &str,
    ) -> Self {
        IoError::InvalidField {
            at: Location::new(source, place),
            field: field.to_string(),
            value: value.to_string(),
            expected: expected.to_string(),
        }
    }

    pub(crate) fn implausible(source: &str, place: Place, what: impl Into<String>) -> Self {
        IoError::Implausible {
            at: Location::new(source, place),
            what: what.into(),
        }
    }

    /// `Err(OverLimit)` when `bytes` (for `what`) exceed the memory limit.
    pub(crate) fn check_memory(
        source: &str,
        place: Place,
        what: impl FnOnce() -> String,
        bytes: f64,
    ) -> Result<(), IoError> {
        match crate::io::limits::over_memory_limit(bytes) {
            None => Ok(()),
            Some((needed, limit)) => Err(IoError::OverLimit {
                at: Location::new(source, place),
                what: what(),
                needed,
                limit,
            }),
        }
    }

    /// Where the error is, if it points into a source.
    pub fn location(&self) -> Option<&Location> {
        match self {
            IoError::Truncated { at, .. }
            | IoError::RecordLength { at, .. }
            | IoError::NotNumeric { at, .. }
            | IoError::NonFinite { at, .. }
            | IoError::InvalidField { at, .. }
            | IoError::AxisMismatch { at, .. }
            | IoError::DuplicateChannel { at, .. }
            | IoError::NoFrf { at, .. }
            | IoError::Csv { at, .. }
            | IoError::Implausible { at, .. }
            | IoError::OverLimit { at, .. } => Some(at),
            IoError::Selection { .. } | IoError::Unwritable { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_source_and_place() {
        let e = IoError::truncated("a.uff", Place::Line(12), "record 7 missing");
        assert!(e.to_string().starts_with("a.uff, line 12: file ends early"));
        let e = IoError::not_numeric("b.uff", Place::Byte(99), "abscissa minimum", b"x1");
        assert!(e.to_string().contains("b.uff, byte offset 99"));
        assert_eq!(e.location().map(|l| l.place), Some(Place::Byte(99)));
    }

    #[test]
    fn long_field_text_is_cut_on_a_char_boundary() {
        let text = "é".repeat(30);
        let e = IoError::not_numeric("c.uff", Place::Line(1), "f", text.as_bytes());
        match e {
            IoError::NotNumeric { text, .. } => assert!(text.len() <= 40),
            other => panic!("unexpected {other:?}"),
        }
    }
}
