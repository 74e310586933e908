//! The binary variant 58b: the header fields on the dataset-number line and
//! the raw record 12 block.
//!
//! The dataset line is `I6,1A1,I6,I6,I12,I12,I6,I6,I12,I12`, e.g.
//! `    58b     1     2          11        5696     0     0           0           0`:
//! `b`, byte order (1 little-endian, 2 big-endian), floating-point format
//! (2 = IEEE 754; 1 DEC and 3 IBM are rejected), number of ASCII lines that
//! follow (11: records 1–11), number of data bytes, four unused fields. The
//! data block starts right after the line feed of record 11 and holds the
//! same values as ASCII record 12 in the same order, 4-byte floats for single
//! and 8-byte floats for double precision (uneven abscissae in the ordinate's
//! precision, as pyuff and the test-software exports do). Writers end the
//! block with `    -1` directly or after a stray CR/LF; both read.
//!
//! **A wrong byte count.** pyuff (through 2.5) writes the count as
//! points × 8 whatever the layout, so a complex-double record declares half
//! its bytes (`58b … 8008` for 1001 points that need 16016). Record 7 (type,
//! points, spacing) and the `-1` delimiter are the authority, as in pyuff's
//! own reader: when the header's count disagrees with record 7 but exactly
//! record 7's bytes lie between record 11 and the delimiter, the data are
//! read and the file gets one [`super::UffWarning::HeaderByteCount`]. A count
//! larger than needed with the delimiter after it is padding and reads
//! silently. Anything else — neither count ends at a delimiter — is a
//! located error naming both counts.

use super::ds58::{ByteOrder, Precision};
use super::text::{Cursor, Line};
use crate::io::error::{IoError, Place};

/// Fields of a `58b` dataset line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BinaryHeader {
    pub byte_order: ByteOrder,
    /// Declared size of the data block; 0 when the writer left it blank.
    pub n_bytes: usize,
    pub place: Place,
}

/// Parses the fields after `b` on a dataset line.
pub(crate) fn parse_binary_header(
    src: &str,
    line: &Line<'_>,
    after_b: &[u8],
) -> Result<BinaryHeader, IoError> {
    let toks: Vec<&[u8]> = after_b
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    let field = |i: usize, name: &str| -> Result<i64, IoError> {
        match toks.get(i) {
            None => Ok(0),
            Some(t) => std::str::from_utf8(t)
                .ok()
                .and_then(|s| s.parse::<i64>().ok())
                .ok_or_else(|| IoError::not_numeric(src, line.place(), name, t)),
        }
    };
    let byte_order = match field(0, "58b byte order")? {
        1 => ByteOrder::Little,
        2 => ByteOrder::Big,
        v => {
            return Err(IoError::invalid(
                src,
                line.place(),
                "58b byte order",
                v,
                "expected 1 (little-endian) or 2 (big-endian)",
            ))
        }
    };
    let fp = field(1, "58b floating-point format")?;
    if fp != 2 && fp != 0 {
        return Err(IoError::invalid(
            src,
            line.place(),
            "58b floating-point format",
            fp,
            "only 2 (IEEE 754) is supported; re-export with IEEE floats",
        ));
    }
    let lines = field(2, "58b number of ASCII lines")?;
    if lines != 11 {
        return Err(IoError::invalid(
            src,
            line.place(),
            "58b number of ASCII lines",
            lines,
            "dataset 58b has 11 header lines (records 1-11)",
        ));
    }
    let n_bytes = field(3, "58b number of bytes")?;
    let n_bytes = usize::try_from(n_bytes).map_err(|_| {
        IoError::invalid(
            src,
            line.place(),
            "58b number of bytes",
            n_bytes,
            "must be ≥ 0",
        )
    })?;
    Ok(BinaryHeader {
        byte_order,
        n_bytes,
        place: line.place(),
    })
}

/// A 58b header whose byte count disagrees with record 7 (read by record 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ByteCountMismatch {
    pub declared: usize,
    pub needed: usize,
    pub place: Place,
}

/// Reads the binary record 12 (`n_values` numbers), leaving the cursor after
/// the block; reports a header byte count that record 7 overrules.
/// `memory(n_values)` is called once the block is known to be in the file,
/// before the values are allocated.
pub(crate) fn read_data(
    cur: &mut Cursor<'_>,
    h: &BinaryHeader,
    n_values: usize,
    precision: Precision,
    memory: &dyn Fn(usize) -> Result<(), IoError>,
) -> Result<(Vec<f64>, Option<ByteCountMismatch>), IoError> {
    let src = cur.source;
    let size = match precision {
        Precision::Single => 4,
        Precision::Double => 8,
    };
    let start = cur.offset();
    let needed = n_values.checked_mul(size).ok_or_else(|| {
        IoError::invalid(
            src,
            h.place,
            "number of points",
            n_values,
            "the byte count overflows",
        )
    })?;
    let declared = if h.n_bytes == 0 { needed } else { h.n_bytes };
    let (take, mismatch) = if declared == needed {
        (needed, None)
    } else if declared > needed && cur.delimiter_after(declared) {
        (declared, None)
    } else if cur.delimiter_after(needed) {
        let m = ByteCountMismatch {
            declared,
            needed,
            place: h.place,
        };
        (needed, Some(m))
    } else if declared < needed || cur.remaining() < declared {
        return Err(IoError::record_length(
            src,
            h.place,
            format!(
                "58b header declares {declared} data bytes but record 7 needs {needed} \
                 ({n_values} values of {size} bytes), and no `-1` delimiter follows either \
                 count; the file is truncated or record 7 is wrong"
            ),
        ));
    } else {
        (declared, None)
    };
    let block = cur.take_bytes(take).ok_or_else(|| {
        IoError::truncated(
            src,
            Place::Byte(start),
            format!(
                "58b data block of {take} bytes starting here, only {} bytes remain",
                cur.remaining()
            ),
        )
    })?;
    // The block is in the file, so `n_values` is bounded by its size; the
    // memory limit is checked before the values are made.
    memory(n_values)?;
    let data = block.get(..needed).unwrap_or_default();
    let mut out = Vec::with_capacity(n_values);
    match (precision, h.byte_order) {
        (Precision::Double, ByteOrder::Little) => {
            out.extend(data.chunks_exact(8).map(|c| f64::from_le_bytes(arr8(c))))
        }
        (Precision::Double, ByteOrder::Big) => {
            out.extend(data.chunks_exact(8).map(|c| f64::from_be_bytes(arr8(c))))
        }
        (Precision::Single, ByteOrder::Little) => out.extend(
            data.chunks_exact(4)
                .map(|c| f64::from(f32::from_le_bytes(arr4(c)))),
        ),
        (Precision::Single, ByteOrder::Big) => out.extend(
            data.chunks_exact(4)
                .map(|c| f64::from(f32::from_be_bytes(arr4(c)))),
        ),
    }
    Ok((out, mismatch))
}

fn arr8(c: &[u8]) -> [u8; 8] {
    let mut a = [0u8; 8];
    a.copy_from_slice(c);
    a
}

fn arr4(c: &[u8]) -> [u8; 4] {
    let mut a = [0u8; 4];
    a.copy_from_slice(c);
    a
}

/// Appends the `    58b …` dataset line.
pub(crate) fn push_binary_header(out: &mut Vec<u8>, order: ByteOrder, n_bytes: usize) {
    let bo = match order {
        ByteOrder::Little => 1,
        ByteOrder::Big => 2,
    };
    out.extend_from_slice(
        format!(
            "{:>6}b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}\n",
            58, bo, 2, 11, n_bytes, 0, 0, 0, 0
        )
        .as_bytes(),
    );
}

/// Appends the binary record 12.
pub(crate) fn push_data(out: &mut Vec<u8>, values: &[f64], order: ByteOrder, precision: Precision) {
    match (precision, order) {
        (Precision::Double, ByteOrder::Little) => {
            out.reserve(values.len() * 8);
            values
                .iter()
                .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        }
        (Precision::Double, ByteOrder::Big) => {
            values
                .iter()
                .for_each(|v| out.extend_from_slice(&v.to_be_bytes()));
        }
        (Precision::Single, ByteOrder::Little) => {
            values
                .iter()
                .for_each(|v| out.extend_from_slice(&(*v as f32).to_le_bytes()));
        }
        (Precision::Single, ByteOrder::Big) => {
            values
                .iter()
                .for_each(|v| out.extend_from_slice(&(*v as f32).to_be_bytes()));
        }
    }
}
