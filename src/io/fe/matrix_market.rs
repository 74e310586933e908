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

use super::{check_size, fail, parse_real, FeError, FeMatrix};

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

/// A 1-based index in `1..=n`, as a 0-based one.
fn index(text: &str, n: usize, line: usize, what: &str) -> Result<usize, FeError> {
    match text.parse::<usize>() {
        Ok(i) if (1..=n).contains(&i) => Ok(i - 1),
        Ok(i) => fail(
            line,
            format!(
                "{what} index {i} is outside the declared {n}×{n} matrix (indices are 1-based, \
                 1..={n}); fix the entry or the size line"
            ),
        ),
        Err(_) => fail(
            line,
            format!("{what} index `{text}` is not a positive integer"),
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
    let entries = read_entries(lines, &declared, text)?;
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

/// The entries of the `lines` after the size line (0-based row, column,
/// value; a symmetric matrix's mirrored), exactly as many as `declared`;
/// `text` is the whole file, whose last line locates a missing entry.
fn read_entries<'a>(
    lines: impl Iterator<Item = (usize, &'a str)>,
    declared: &Declared,
    text: &str,
) -> Result<Vec<(usize, usize, f64)>, FeError> {
    let Declared {
        n,
        nnz,
        line: size_line,
        symmetric,
    } = *declared;
    let mut entries = Vec::new();
    let mut read = 0usize;
    for (k, raw) in lines {
        let line = k + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        if read == nnz {
            return fail(
                line,
                format!("more entries than the {nnz} the size line (line {size_line}) declares"),
            );
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        let [i, j, v] = f[..] else {
            return fail(
                line,
                format!("{} fields: an entry is `row column value`", f.len()),
            );
        };
        let (i, j) = (index(i, n, line, "row")?, index(j, n, line, "column")?);
        let v = parse_real(v).ok_or_else(|| FeError {
            line,
            message: format!("value `{v}` is not a finite number"),
        })?;
        entries.push((i, j, v));
        if symmetric && i != j {
            entries.push((j, i, v));
        }
        read += 1;
    }
    if read < nnz {
        return fail(
            text.lines().count().max(1),
            format!("the file ends after {read} of the {nnz} entries the size line (line {size_line}) declares"),
        );
    }
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BANNER: &str = "%%MatrixMarket matrix coordinate real symmetric\n";

    fn read(body: &str) -> Result<FeMatrix, FeError> {
        read_matrix_market(&format!("{BANNER}{body}"))
    }

    #[test]
    fn symmetric_entries_are_mirrored() {
        let m = read("% exported\n\n2 2 2\n1 1 2.0\n2 1 -1\n").unwrap();
        assert_eq!(m.n, 2);
        assert_eq!(m.entries, vec![(0, 0, 2.0), (1, 0, -1.0), (0, 1, -1.0)]);
        let g =
            read_matrix_market("%%MatrixMarket matrix coordinate integer general\n2 2 1\n1 2 3\n")
                .unwrap();
        assert_eq!(g.entries, vec![(0, 1, 3.0)]);
    }

    #[test]
    fn absurd_sizes_are_refused_before_allocating() {
        let e = read("1000000000000 1000000000000 1000000000000\n1 1 1\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("room for at most"), "{e}");
        // Few entries, rows beyond any memory limit.
        let e = read("1000000000000000 1000000000000000 1\n1 1 1\n").unwrap_err();
        assert!(e.message.contains("memory limit"), "{e}");
        let e = read("99999999999999999999999 3 1\n").unwrap_err();
        assert!(e.message.contains("three non-negative integers"), "{e}");
        assert!(read("3 4 1\n1 1 1\n").is_err());
    }

    #[test]
    fn out_of_range_and_malformed_entries_name_their_line() {
        let e = read("3 3 2\n1 1 1\n4 1 1\n").unwrap_err();
        assert_eq!(e.line, 4);
        assert!(e.message.contains("row index 4 is outside"), "{e}");
        let e = read("3 3 1\n1 0 1\n").unwrap_err();
        assert!(e.message.contains("column index 0"), "{e}");
        let e = read("3 3 1\n1 1 nan\n").unwrap_err();
        assert!(e.message.contains("not a finite number"), "{e}");
        let e = read("3 3 2\n1 1 1\n\n\n\n\n\n\n").unwrap_err();
        assert!(e.message.contains("after 1 of the 2"), "{e}");
        let e = read("3 3 2\n1 1 1\n").unwrap_err();
        assert!(
            e.message.contains("room for at most 1 entry line(s)"),
            "{e}"
        );
        let e = read("3 3 1\n1 1 1\n2 2 1\n").unwrap_err();
        assert_eq!(e.line, 4);
        let e = read_matrix_market("%%MatrixMarket matrix array real general\n").unwrap_err();
        assert!(e.message.contains("coordinate"), "{e}");
        assert!(read_matrix_market("").is_err());
    }
}
