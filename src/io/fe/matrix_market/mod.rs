//! Matrix Market coordinate matrices (Boisvert, Pozo & Remington, "The
//! Matrix Market Exchange Formats: Initial Design", NISTIR 5935, 1996), as
//! FE codes and scipy's `mmwrite` export mass and stiffness matrices:
//!
//! ```text
//! %%MatrixMarket matrix coordinate real symmetric
//! % comments
//! 3 3 4                      rows, columns, entries
//! 1 1 2.0                    1-based row, column, value
//! 2 1 -1.0
//! ```
//!
//! `real` and `integer` fields with `general`, `symmetric` (one triangle
//! given, mirrored here) or `hermitian` (the same for real values) symmetry
//! are read; `array`, `complex`, `pattern` and `skew-symmetric` are
//! refused with what to export instead. The header's sizes are checked
//! before anything is allocated: the entry count against the bytes that
//! follow (an entry line takes at least 6 bytes, `1 1 1\n`), rows and entries
//! against the memory limit; entries are then collected as they are read, and
//! an index of 0 or beyond the declared size is an error at its line.

mod entries;
#[cfg(test)]
mod tests;

use super::{check_size, fail, FeError, FeMatrix};

/// Fewest bytes of one entry line: `i j v` and its line feed.
const MIN_ENTRY_BYTES: usize = 6;

/// The banner's symmetry: whether one triangle is given.
fn banner(line: &str) -> Result<bool, FeError> {
    let t: Vec<String> = line
        .split_whitespace()
        .map(str::to_ascii_lowercase)
        .collect();
    let word = |i: usize| t.get(i).map(String::as_str).unwrap_or("");
    if word(0) != "%%matrixmarket" || word(1) != "matrix" {
        return fail(
            1,
            "the first line must be a banner like `%%MatrixMarket matrix coordinate real symmetric`",
        );
    }
    match word(2) {
        "coordinate" => {}
        "array" => {
            return fail(
                1,
                "dense `array` format is not read; export the matrix in `coordinate` format",
            )
        }
        other => return fail(1, format!("format `{other}`: expected `coordinate`")),
    }
    match word(3) {
        "real" | "integer" => {}
        other => {
            return fail(
                1,
                format!(
                "field `{other}`: only `real` or `integer` mass and stiffness matrices are read"
            ),
            )
        }
    }
    match word(4) {
        "general" => Ok(false),
        "symmetric" | "hermitian" => Ok(true),
        other => fail(
            1,
            format!("symmetry `{other}`: mass and stiffness matrices are `symmetric` or `general`"),
        ),
    }
}

/// Read a square real Matrix Market coordinate matrix.
pub fn read_matrix_market(text: &str) -> Result<FeMatrix, FeError> {
    let mut lines = text.split_inclusive('\n').enumerate();
    let first = lines.next().map(|(_, l)| l).unwrap_or("");
    let symmetric = banner(first)?;
    let mut consumed = first.len();
    // The size line: the first line after the banner that is neither a
    // comment nor blank.
    let (size_line, sizes) = loop {
        let Some((k, raw)) = lines.next() else {
            return fail(
                1,
                "the file ends before the size line `rows columns entries`",
            );
        };
        consumed += raw.len();
        let t = raw.trim();
        if !t.is_empty() && !t.starts_with('%') {
            break (k + 1, t);
        }
    };
    let remaining = text.len().saturating_sub(consumed);
    let declared = declared_size(sizes, size_line, remaining, symmetric)?;
    let shape = entries::Shape {
        n: declared.n,
        nnz: declared.nnz,
        size_line: declared.line,
        symmetric: declared.symmetric,
    };
    let entries = entries::read_entries(&text[consumed..], size_line + 1, shape)?;
    Ok(FeMatrix {
        n: declared.n,
        entries,
        labels: None,
    })
}

/// What the size line declares, checked.
struct Declared {
    /// Rows (= columns).
    n: usize,
    /// Entries given.
    nnz: usize,
    /// The size line's number.
    line: usize,
    /// One triangle given, mirrored.
    symmetric: bool,
}

/// The size line `sizes` (line `size_line`) checked before anything is
/// allocated: a square, non-empty matrix whose entries fit in the
/// `remaining` bytes and, with a symmetric matrix's mirrored ones, in the
/// memory limit.
fn declared_size(
    sizes: &str,
    size_line: usize,
    remaining: usize,
    symmetric: bool,
) -> Result<Declared, FeError> {
    let fields: Vec<&str> = sizes.split_whitespace().collect();
    let parsed: Option<Vec<usize>> = fields.iter().map(|f| f.parse().ok()).collect();
    let (rows, cols, nnz) = match parsed.as_deref() {
        Some(&[r, c, e]) => (r, c, e),
        _ => {
            return fail(
                size_line,
                format!(
                "size line `{sizes}`: expected three non-negative integers `rows columns entries`"
            ),
            )
        }
    };
    if rows != cols {
        return fail(
            size_line,
            format!("matrix is {rows}×{cols}, expected square"),
        );
    }
    if rows == 0 {
        return fail(size_line, "matrix has no rows");
    }
    let possible = (remaining + 1) / MIN_ENTRY_BYTES;
    if nnz > possible {
        return fail(
            size_line,
            format!(
                "the size line declares {nnz} entries but only {remaining} bytes follow, room for \
                 at most {possible} entry line(s); the size line is wrong or the file is truncated"
            ),
        );
    }
    let stored = if symmetric {
        nnz.saturating_mul(2)
    } else {
        nnz
    };
    check_size(size_line, rows, stored)?;
    Ok(Declared {
        n: rows,
        nnz,
        line: size_line,
        symmetric,
    })
}
