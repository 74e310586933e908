//! The entry lines of a Matrix Market coordinate file (`row column value`
//! after the size line), scanned as bytes: the reader's hot loop.
//!
//! A 190k-DOF solid exports ~13 million entry lines (~0.5 GB). The lines
//! are cut into chunks of [`CHUNK_BYTES`] at line feeds and scanned in
//! parallel; the chunks' entries are concatenated in file order, so the
//! result is the same whatever the thread count. Per line: indices are
//! parsed digit by digit, the value by `str::parse::<f64>` (correctly
//! rounded, Eisel–Lemire since Rust 1.55, the algorithm of the fast-float
//! crates) with the Fortran `D` exponent as a fallback
//! ([`super::super::parse_real`]); non-finite values are refused. The
//! errors and their line numbers are those of a line-by-line reading: the
//! first problem in file order wins, an entry beyond the declared count
//! included.

use super::super::{fail, parse_real, FeError};
use rayon::prelude::*;

/// Bytes of entry lines one task scans: large enough that the per-chunk
/// work (a vector, a line count) is negligible, small enough to balance.
const CHUNK_BYTES: usize = 4 << 20;

/// What one chunk held: its entries (a symmetric matrix's mirrored), the
/// entry lines read, its line feeds, and the first problem (0-based line
/// within the chunk, message) with the entry lines read before it.
struct Chunk {
    entries: Vec<(usize, usize, f64)>,
    given: usize,
    newlines: usize,
    error: Option<(usize, String)>,
}

/// The matrix shape the entries must fit.
#[derive(Clone, Copy)]
pub(super) struct Shape {
    /// Rows (= columns).
    pub n: usize,
    /// Entries the size line declares.
    pub nnz: usize,
    /// The size line's number, for messages.
    pub size_line: usize,
    /// One triangle given, mirrored.
    pub symmetric: bool,
}

/// The entries of `body` (the text after the size line, whose first line
/// is line `first_line` of the file), exactly `shape.nnz` of them.
pub(super) fn read_entries(
    body: &str,
    first_line: usize,
    shape: Shape,
) -> Result<Vec<(usize, usize, f64)>, FeError> {
    let ranges = chunk_ranges(body.as_bytes());
    let chunks: Vec<Chunk> = ranges
        .par_iter()
        .map(|r| scan(&body[r.clone()], shape))
        .collect();
    let mut given = 0usize;
    let mut line0 = first_line;
    for (c, r) in chunks.iter().zip(&ranges) {
        if given + c.given > shape.nnz {
            let local = nth_entry_line(&body[r.clone()], shape.nnz - given);
            return fail(
                line0 + local,
                format!(
                    "more entries than the {} the size line (line {}) declares",
                    shape.nnz, shape.size_line
                ),
            );
        }
        if let Some((local, message)) = &c.error {
            return fail(line0 + local, message.clone());
        }
        given += c.given;
        line0 += c.newlines;
    }
    if given < shape.nnz {
        let last = (first_line - 1 + body.lines().count()).max(1);
        return fail(
            last,
            format!(
                "the file ends after {given} of the {} entries the size line (line {}) declares",
                shape.nnz, shape.size_line
            ),
        );
    }
    Ok(concatenate(chunks))
}

/// The chunks' entries in file order (one move when there is one chunk).
fn concatenate(mut chunks: Vec<Chunk>) -> Vec<(usize, usize, f64)> {
    if chunks.len() == 1 {
        return std::mem::take(&mut chunks[0].entries);
    }
    let total = chunks.iter().map(|c| c.entries.len()).sum();
    let mut out = Vec::with_capacity(total);
    for c in chunks {
        out.extend_from_slice(&c.entries);
    }
    out
}

/// Byte ranges of about [`CHUNK_BYTES`] each, every one ending after a
/// line feed (the last at the end of `b`).
fn chunk_ranges(b: &[u8]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < b.len() {
        let mut end = (start + CHUNK_BYTES).min(b.len());
        if end < b.len() {
            end = memchr::memchr(b'\n', &b[end..]).map_or(b.len(), |k| end + k + 1);
        }
        out.push(start..end);
        start = end;
    }
    out
}

/// ASCII white space inside a line (the line feed ends it).
fn is_space(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Whether a line (without its line feed) holds no entry: blank or a
/// `%` comment.
fn is_entry(l: &[u8]) -> bool {
    l.iter()
        .find(|c| !is_space(**c))
        .is_some_and(|&c| c != b'%')
}

/// The 0-based line within `chunk` of its `k`-th (0-based) entry line.
fn nth_entry_line(chunk: &str, k: usize) -> usize {
    chunk
        .split('\n')
        .enumerate()
        .filter(|(_, l)| is_entry(l.as_bytes()))
        .nth(k)
        .map_or(0, |(i, _)| i)
}

/// Scan one chunk of whole lines.
fn scan(chunk: &str, shape: Shape) -> Chunk {
    let b = chunk.as_bytes();
    let newlines = memchr::memchr_iter(b'\n', b).count();
    // At most one entry a line; never more than declared (the size line's
    // count is bounded by the memory limit before this runs).
    let per = if shape.symmetric { 2 } else { 1 };
    let mut entries = Vec::with_capacity((newlines + 1).min(shape.nnz) * per);
    let mut given = 0;
    let mut pos = 0;
    let mut line = 0;
    while pos < b.len() {
        let end = memchr::memchr(b'\n', &b[pos..]).map_or(b.len(), |k| pos + k);
        match entry(chunk, pos, end, shape.n) {
            Ok(None) => {}
            Ok(Some((i, j, v))) => {
                entries.push((i, j, v));
                if shape.symmetric && i != j {
                    entries.push((j, i, v));
                }
                given += 1;
            }
            Err(message) => {
                return Chunk {
                    entries,
                    given,
                    newlines,
                    error: Some((line, message)),
                }
            }
        }
        pos = end + 1;
        line += 1;
    }
    Chunk {
        entries,
        given,
        newlines,
        error: None,
    }
}

/// The line `text[start..end]`: `None` when blank or a comment, else its
/// 0-based row, column and value.
fn entry(
    text: &str,
    start: usize,
    end: usize,
    n: usize,
) -> Result<Option<(usize, usize, f64)>, String> {
    let b = text.as_bytes();
    // Field boundaries: at most three fields and a marker of a fourth.
    let mut fields = [(0usize, 0usize); 3];
    let mut count = 0;
    let mut k = start;
    loop {
        while k < end && is_space(b[k]) {
            k += 1;
        }
        if k == end {
            break;
        }
        if count == 0 && b[k] == b'%' {
            return Ok(None);
        }
        let s = k;
        while k < end && !is_space(b[k]) {
            k += 1;
        }
        if count == 3 {
            count += 1;
            break;
        }
        fields[count] = (s, k);
        count += 1;
    }
    if count == 0 {
        return Ok(None);
    }
    if count != 3 {
        // Slicing at ASCII white space keeps char boundaries.
        let all = text[start..end].split_whitespace().count();
        return Err(format!("{all} fields: an entry is `row column value`"));
    }
    // Field boundaries sit next to ASCII bytes: valid `str` slices.
    let field = |f: (usize, usize)| &text[f.0..f.1];
    let i = index(field(fields[0]), n, "row")?;
    let j = index(field(fields[1]), n, "column")?;
    let v = field(fields[2]);
    let value = match v.parse::<f64>() {
        Ok(x) => Some(x).filter(|x| x.is_finite()),
        Err(_) => parse_real(v),
    };
    match value {
        Some(x) => Ok(Some((i, j, x))),
        None => Err(format!("value `{v}` is not a finite number")),
    }
}

/// A 1-based index in `1..=n` (digits, an optional `+`), as a 0-based one.
fn index(text: &str, n: usize, what: &str) -> Result<usize, String> {
    let digits = text.strip_prefix('+').unwrap_or(text).as_bytes();
    let mut i: usize = 0;
    let mut ok = !digits.is_empty();
    for &d in digits {
        let next = i
            .checked_mul(10)
            .and_then(|x| x.checked_add(usize::from(d.wrapping_sub(b'0'))));
        match next {
            Some(x) if d.is_ascii_digit() => i = x,
            _ => {
                ok = false;
                break;
            }
        }
    }
    if !ok {
        return Err(format!("{what} index `{text}` is not a positive integer"));
    }
    if (1..=n).contains(&i) {
        return Ok(i - 1);
    }
    Err(format!(
        "{what} index {i} is outside the declared {n}×{n} matrix (indices are 1-based, 1..={n}); \
         fix the entry or the size line"
    ))
}
