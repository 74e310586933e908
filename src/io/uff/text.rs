//! Byte-level reading and writing of UFF text records: a line cursor that
//! tracks line numbers and byte offsets, Fortran fixed-column fields
//! (`I10`, `20A1`; blank numeric fields read as zero, as Fortran does),
//! free-format number tokens (`E13.5`, `E20.12`, `D25.16` written by any tool)
//! and the Fortran `Ew.d` output format.
//!
//! Number fields are split on whitespace rather than sliced at fixed columns, so
//! files whose writers used other widths still read; fields that touch because
//! a negative number filled its whole width (`4.1E+03-3.1E+03`, seen in real
//! dataset 55 files) are split at the sign.

use crate::io::error::{IoError, Place};

/// One line of a UFF file without its `\n`/`\r\n` terminator.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Line<'a> {
    pub text: &'a [u8],
    /// 1-based line number.
    pub number: usize,
}

impl<'a> Line<'a> {
    pub fn place(&self) -> Place {
        Place::Line(self.number)
    }

    /// The line with surrounding whitespace removed.
    pub fn trimmed(&self) -> &'a [u8] {
        self.text.trim_ascii()
    }

    /// True for the `    -1` line that opens and closes every dataset.
    pub fn is_delimiter(&self) -> bool {
        self.trimmed() == b"-1"
    }
}

/// Sequential reader over the lines (and, for 58b, raw bytes) of one file.
pub(crate) struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Number of line terminators passed so far.
    lines_done: usize,
    pub source: &'a str,
}

impl<'a> Cursor<'a> {
    pub fn new(bytes: &'a [u8], source: &'a str) -> Self {
        Cursor {
            bytes,
            pos: 0,
            lines_done: 0,
            source,
        }
    }

    pub fn at_eof(&self) -> bool {
        self.pos >= self.bytes.len()
    }

    pub fn offset(&self) -> usize {
        self.pos
    }

    pub fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// Place of the next line to be read (for "file ends early" errors).
    pub fn next_place(&self) -> Place {
        Place::Line(self.lines_done + 1)
    }

    pub fn next_line(&mut self) -> Option<Line<'a>> {
        if self.at_eof() {
            return None;
        }
        let rest = &self.bytes[self.pos..];
        let (raw, advance) = match memchr::memchr(b'\n', rest) {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        let text = raw.strip_suffix(b"\r").unwrap_or(raw);
        self.pos += advance;
        self.lines_done += 1;
        Some(Line {
            text,
            number: self.lines_done,
        })
    }

    pub fn peek_line(&self) -> Option<Line<'a>> {
        let mut probe = Cursor { ..*self };
        probe.next_line()
    }

    /// Skips lines holding only whitespace (stray CR/LF some writers leave).
    pub fn skip_blank_lines(&mut self) {
        while let Some(l) = self.peek_line() {
            if !l.trimmed().is_empty() {
                break;
            }
            self.next_line();
        }
    }

    /// Takes `n` raw bytes (58b data), keeping the line count in step.
    pub fn take_bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let chunk = self.bytes.get(self.pos..end)?;
        self.lines_done += memchr::memchr_iter(b'\n', chunk).count();
        self.pos = end;
        Some(chunk)
    }

    /// Whether skipping `n` raw bytes lands exactly on a `    -1` delimiter
    /// line (I6: four spaces, then -1; directly or after one stray CR/LF),
    /// which is how the 58b byte-count check tells data from the next line.
    pub fn delimiter_after(&self, n: usize) -> bool {
        let Some(rest) = self.pos.checked_add(n).and_then(|at| self.bytes.get(at..)) else {
            return false;
        };
        let rest = rest
            .strip_prefix(b"\r\n")
            .or_else(|| rest.strip_prefix(b"\n"))
            .unwrap_or(rest);
        rest.strip_prefix(b"    -1")
            .is_some_and(|t| t.is_empty() || t[0] == b'\n' || t[0] == b'\r' || t[0] == b' ')
    }

    /// Next line, or a "file ends early" error naming `what` was expected.
    pub fn expect_line(&mut self, what: &str) -> Result<Line<'a>, IoError> {
        let place = self.next_place();
        self.next_line()
            .ok_or_else(|| IoError::truncated(self.source, place, format!("expected {what}")))
    }

    /// Next line of a fixed header record: a `-1` there means the dataset
    /// ended before its header did.
    pub fn expect_record(&mut self, what: &str) -> Result<Line<'a>, IoError> {
        let line = self.expect_line(what)?;
        if line.is_delimiter() {
            return Err(IoError::truncated(
                self.source,
                line.place(),
                format!("the dataset ends (`-1`) where {what} should be"),
            ));
        }
        Ok(line)
    }

    /// Consumes the closing `-1` of a dataset (after optional blank lines).
    pub fn expect_delimiter(&mut self, dataset: &str) -> Result<(), IoError> {
        self.skip_blank_lines();
        let place = self.next_place();
        match self.next_line() {
            Some(l) if l.is_delimiter() => Ok(()),
            Some(l) => Err(IoError::record_length(
                self.source,
                l.place(),
                format!(
                    "expected the `-1` line that ends dataset {dataset}, found {:?}; \
                     the data block holds more values than its header declares",
                    String::from_utf8_lossy(&l.text[..l.text.len().min(40)])
                ),
            )),
            None => Err(IoError::truncated(
                self.source,
                place,
                format!("expected the `-1` line that ends dataset {dataset}"),
            )),
        }
    }
}

/// A header line as characters, for slicing Fortran fixed columns. Columns are
/// counted in characters when the line is UTF-8 (tools pad `m/s²` by
/// characters), else in bytes.
pub(crate) struct Columns {
    chars: Vec<char>,
    pub place: Place,
}

impl Columns {
    pub fn new(line: &Line<'_>) -> Self {
        let chars = match std::str::from_utf8(line.text) {
            Ok(s) => s.chars().collect(),
            Err(_) => line.text.iter().map(|&b| char::from(b)).collect(),
        };
        Columns {
            chars,
            place: line.place(),
        }
    }

    /// Characters `start..end` (0-based, end exclusive), trimmed; empty past the end.
    pub fn text(&self, start: usize, end: usize) -> String {
        let end = end.min(self.chars.len());
        let start = start.min(end);
        self.chars[start..end]
            .iter()
            .collect::<String>()
            .trim()
            .to_string()
    }

    /// Integer field in columns `start..end`; blank reads as 0 (Fortran BN).
    pub fn int(&self, source: &str, start: usize, end: usize, field: &str) -> Result<i64, IoError> {
        let t = self.text(start, end);
        if t.is_empty() {
            return Ok(0);
        }
        t.parse::<i64>()
            .map_err(|_| IoError::not_numeric(source, self.place, field, t.as_bytes()))
    }
}

/// Splits a line into number tokens: whitespace-separated, and touching
/// fields split before a sign that follows a digit or point (`1.0E+03-2.0E+03`).
pub(crate) fn tokens(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    text.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .flat_map(split_touching)
}

fn split_touching(tok: &[u8]) -> SplitTouching<'_> {
    SplitTouching { rest: tok }
}

struct SplitTouching<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for SplitTouching<'a> {
    type Item = &'a [u8];
    fn next(&mut self) -> Option<&'a [u8]> {
        if self.rest.is_empty() {
            return None;
        }
        let cut = (1..self.rest.len()).find(|&i| {
            matches!(self.rest[i], b'+' | b'-')
                && (self.rest[i - 1].is_ascii_digit() || self.rest[i - 1] == b'.')
        });
        let (head, tail) = self.rest.split_at(cut.unwrap_or(self.rest.len()));
        self.rest = tail;
        Some(head)
    }
}

/// Parses a float token; accepts Fortran `D` exponents.
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    parse_float(tok)
}

/// Parses a float token directly to `f32` (single-precision records), so the
/// value is the correctly rounded `f32` of the text.
pub(crate) fn parse_f32(tok: &[u8]) -> Option<f32> {
    parse_float(tok)
}

fn parse_float<T: std::str::FromStr>(tok: &[u8]) -> Option<T> {
    if let Some(v) = std::str::from_utf8(tok).ok().and_then(|s| s.parse().ok()) {
        return Some(v);
    }
    let fixed: Vec<u8> = tok
        .iter()
        .map(|&b| if b == b'D' || b == b'd' { b'E' } else { b })
        .collect();
    std::str::from_utf8(&fixed).ok()?.parse().ok()
}

/// Reads exactly `n` numbers from the following lines (records that may wrap
/// over several lines, e.g. 58 record 12 or 55 records 7-10). `single` rounds
/// to `f32`. Stops at the line that completes the count; a dataset end (`-1`)
/// first is a truncation, a line with more numbers than needed a length error.
pub(crate) fn read_numbers(
    cur: &mut Cursor<'_>,
    n: usize,
    single: bool,
    what: &str,
    out: &mut Vec<f64>,
) -> Result<(), IoError> {
    let src = cur.source;
    read_numbers_checked(cur, n, single, what, out, &mut |_, v, place| {
        finite(src, place, what, v)
    })
}

/// A value read at `place` of `src` for `what`: finite, or the error that
/// says where it is not.
pub(crate) fn finite(src: &str, place: Place, what: &str, v: f64) -> Result<(), IoError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(IoError::NonFinite {
            at: crate::io::error::Location::new(src, place),
            field: what.to_string(),
            value: v,
        })
    }
}

/// [`read_numbers`] with `check(index, value, place)` called on every value
/// as it is read (`index` counts from 0 within this call), so a value the
/// caller refuses is reported at its own line; the check decides whether a
/// non-finite value is refused ([`finite`]). `out` grows as values are
/// read; nothing is reserved from `n`.
pub(crate) fn read_numbers_checked(
    cur: &mut Cursor<'_>,
    n: usize,
    single: bool,
    what: &str,
    out: &mut Vec<f64>,
    check: &mut dyn FnMut(usize, f64, Place) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let first = out.len();
    let target = first.saturating_add(n);
    while out.len() < target {
        let place = cur.next_place();
        let line = match cur.next_line() {
            Some(l) if !l.is_delimiter() => l,
            _ => {
                return Err(IoError::truncated(
                    cur.source,
                    place,
                    format!(
                        "{what}: found {} of {n} values before the end of the dataset",
                        n - (target - out.len())
                    ),
                ))
            }
        };
        for tok in tokens(line.text) {
            if out.len() == target {
                return Err(IoError::record_length(
                    cur.source,
                    line.place(),
                    format!("{what}: more values than the {n} the header declares"),
                ));
            }
            let v = if single {
                parse_f32(tok).map(f64::from)
            } else {
                parse_f64(tok)
            };
            let v = v.ok_or_else(|| IoError::not_numeric(cur.source, line.place(), what, tok))?;
            check(out.len() - first, v, line.place())?;
            out.push(v);
        }
    }
    Ok(())
}

/// Appends `x` in Fortran `Ew.d` form (`-1.23456E+00`, exponent at least two
/// digits), right-aligned in `width` characters. `single` formats the `f32`
/// rounding of `x`.
pub(crate) fn push_e(out: &mut Vec<u8>, x: f64, width: usize, decimals: usize, single: bool) {
    let s = if single {
        format!("{:.*e}", decimals, x as f32)
    } else {
        format!("{:.*e}", decimals, x)
    };
    let body = match s.split_once('e') {
        Some((mantissa, exp)) => {
            let e: i32 = exp.parse().unwrap_or(0);
            let sign = if e < 0 { '-' } else { '+' };
            format!("{mantissa}E{sign}{:02}", e.unsigned_abs())
        }
        None => s,
    };
    for _ in body.len()..width {
        out.push(b' ');
    }
    out.extend_from_slice(body.as_bytes());
}

/// Appends `s` left-aligned and padded or cut to exactly `width` characters.
pub(crate) fn push_fixed_str(out: &mut Vec<u8>, s: &str, width: usize) {
    let mut n = 0;
    for c in s.chars().filter(|c| !c.is_control()) {
        if n == width {
            break;
        }
        let mut buf = [0u8; 4];
        out.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
        n += 1;
    }
    for _ in n..width {
        out.push(b' ');
    }
}

/// Appends an ID line (records 1-5): the text without line breaks, padded to 80.
pub(crate) fn push_id_line(out: &mut Vec<u8>, s: &str) {
    let clean: String = s.chars().filter(|c| *c != '\n' && *c != '\r').collect();
    out.extend_from_slice(clean.as_bytes());
    for _ in clean.chars().count()..80 {
        out.push(b' ');
    }
    out.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cursor_counts_lines_and_strips_crlf() {
        let mut c = Cursor::new(b"    -1\r\n    58\r\nabc", "t");
        let l = c.next_line().unwrap();
        assert!(l.is_delimiter());
        assert_eq!(c.next_line().unwrap().text, b"    58");
        let l = c.next_line().unwrap();
        assert_eq!((l.text, l.number), (&b"abc"[..], 3));
        assert!(c.next_line().is_none());
    }

    #[test]
    fn touching_fields_split_at_sign() {
        let t: Vec<&[u8]> = tokens(b"-1.1E-01 4.1E+01 4.1E+03-3.1E+03-1.0E+05").collect();
        assert_eq!(t.len(), 5);
        assert_eq!(t[3], b"-3.1E+03");
        assert_eq!(parse_f64(t[2]), Some(4100.0));
    }

    #[test]
    fn fortran_d_exponent_parses() {
        assert_eq!(parse_f64(b"-2.73149999999999960D+02"), Some(-273.15));
        assert_eq!(parse_f64(b"1.5d0"), Some(1.5));
        assert_eq!(parse_f64(b"abc"), None);
    }

    #[test]
    fn e_format_matches_fortran() {
        let mut out = Vec::new();
        push_e(&mut out, -0.0147553, 13, 5, false);
        push_e(&mut out, 1.0e-300, 13, 5, false);
        push_e(&mut out, 0.0, 20, 11, false);
        assert_eq!(
            String::from_utf8(out).unwrap(),
            " -1.47553E-02 1.00000E-300   0.00000000000E+00"
        );
    }

    #[test]
    fn read_numbers_detects_short_and_long_records() {
        let mut c = Cursor::new(b" 1.0 2.0\n 3.0\n    -1\n", "t");
        let mut v = Vec::new();
        let e = read_numbers(&mut c, 4, false, "data", &mut v).unwrap_err();
        assert!(matches!(e, IoError::Truncated { .. }), "{e}");
        let mut c = Cursor::new(b" 1.0 2.0 3.0\n", "t");
        let e = read_numbers(&mut c, 2, false, "data", &mut Vec::new()).unwrap_err();
        assert!(matches!(e, IoError::RecordLength { .. }), "{e}");
        let mut c = Cursor::new(b" 1.0 NaN\n", "t");
        let e = read_numbers(&mut c, 2, false, "data", &mut Vec::new()).unwrap_err();
        assert!(matches!(e, IoError::NonFinite { .. }), "{e}");
    }

    #[test]
    fn columns_count_characters() {
        let line = Line {
            text: "         0    0 g²/Hz                m/s²".as_bytes(),
            number: 4,
        };
        let c = Columns::new(&line);
        assert_eq!(c.text(16, 36), "g²/Hz");
        assert_eq!(c.text(37, 57), "m/s²");
        assert_eq!(c.int("t", 0, 10, "x").unwrap(), 0);
        assert_eq!(c.int("t", 100, 110, "x").unwrap(), 0);
    }
}
