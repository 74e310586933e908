//! Harwell–Boeing sparse matrices (Duff, Grimes & Lewis, "Users' guide for
//! the Harwell-Boeing sparse matrix collection", 1992), as ANSYS `HBMAT`
//! writes stiffness and mass matrices:
//!
//! ```text
//! line 1  title (A72), key (A8)
//! line 2  TOTCRD PTRCRD INDCRD VALCRD RHSCRD           (5I14)
//! line 3  MXTYPE, NROW NCOL NNZERO NELTVL             (A3, 11X, 4I14)
//! line 4  PTRFMT INDFMT VALFMT RHSFMT                 (2A16, 2A20)
//! line 5  right-hand-side header, only if RHSCRD > 0
//! then    column pointers, row indices, values in those Fortran formats
//! ```
//!
//! `RSA` (real symmetric assembled: one triangle stored, mirrored here) and
//! `RUA` are read; fields are cut by the formats' widths, since Fortran
//! `E` fields may touch (`-1.0E+00-2.0E+00`). ANSYS writes the node and DOF
//! of each equation to `<name>.MAPPING` with `HBMAT, …, Mapping = YES`;
//! [`read_ansys_mapping`] reads it.

use super::{check_size, fail, parse_real, DofLabel, FeError, FeMatrix};

/// Count and width of a Fortran edit descriptor such as `(10I8)`,
/// `(1P,4E20.12)` or `(3D25.16)`.
fn format_width(fmt: &str) -> Option<(usize, usize)> {
    let f = fmt.trim().trim_start_matches('(').trim_end_matches(')');
    let f = f.rsplit(',').next()?.trim().to_ascii_uppercase();
    let letter = f.find(|c: char| c.is_ascii_alphabetic())?;
    let count = if letter == 0 {
        1
    } else {
        f[..letter].parse().ok()?
    };
    let rest = &f[letter + 1..];
    let width = rest.split('.').next()?.parse().ok()?;
    (count > 0 && width > 0).then_some((count, width))
}

/// Fields of `width` characters (at most `count` per line) of lines
/// `start..start + cards`, until `wanted` fields are read.
fn fixed_fields<'a>(
    lines: &[&'a str],
    start: usize,
    cards: usize,
    (count, width): (usize, usize),
    wanted: usize,
    what: &str,
) -> Result<Vec<(usize, &'a str)>, FeError> {
    // Grows with the fields actually read; the caller bounded `wanted`.
    let mut out = Vec::new();
    for (k, line) in lines.iter().enumerate().skip(start).take(cards) {
        let mut pos = 0;
        for _ in 0..count {
            if out.len() == wanted || pos >= line.len() {
                break;
            }
            let end = pos.saturating_add(width).min(line.len());
            let field = line.get(pos..end).unwrap_or("").trim();
            if !field.is_empty() {
                out.push((k + 1, field));
            }
            pos = end;
        }
    }
    if out.len() < wanted {
        return fail(
            start.saturating_add(cards).min(lines.len()).max(1),
            format!("{what}: found {} of {wanted} entries", out.len()),
        );
    }
    Ok(out)
}

fn header_ints(line: &str, n: usize, at: usize, what: &str) -> Result<Vec<usize>, FeError> {
    let v: Vec<usize> = line
        .split_whitespace()
        .take(n)
        .map(|t| t.parse::<usize>())
        .collect::<Result<_, _>>()
        .or_else(|_| fail(at, format!("{what}: expected {n} integers")))?;
    if v.len() < n {
        return fail(
            at,
            format!("{what}: expected {n} integers, found {}", v.len()),
        );
    }
    Ok(v)
}

/// Read a real assembled Harwell–Boeing matrix (`RSA` or `RUA`).
pub fn read_harwell_boeing(text: &str) -> Result<FeMatrix, FeError> {
    let lines: Vec<&str> = text.lines().collect();
    let h = parse_header(&lines)?;
    let start = h.start;
    let (ind_start, val_start) = (
        start.saturating_add(h.ptrcrd),
        start.saturating_add(h.ptrcrd).saturating_add(h.indcrd),
    );
    check_sizes(&lines, &h, ind_start, val_start)?;
    let ptr = fixed_fields(&lines, start, h.ptrcrd, h.pf, h.n_ptr, "column pointers")?;
    let ind = fixed_fields(&lines, ind_start, h.indcrd, h.inf, h.nnz, "row indices")?;
    let val = fixed_fields(&lines, val_start, h.valcrd, h.vf, h.nnz, "values")?;
    let entries = assemble_entries(&h, &ptr, &ind, &val)?;
    Ok(FeMatrix {
        n: h.nrow,
        entries,
        labels: None,
    })
}

/// What the header lines say (line 5, the right-hand side's, is skipped).
struct Header {
    /// Card counts of the pointers, indices and values.
    ptrcrd: usize,
    indcrd: usize,
    valcrd: usize,
    nrow: usize,
    ncol: usize,
    nnz: usize,
    /// NCOL + 1 (the pointers' count) and NNZERO + 1 (the last pointer).
    n_ptr: usize,
    nnz_end: usize,
    /// `RSA`: one triangle is stored.
    symmetric: bool,
    /// (count, width) of the pointer, index and value formats.
    pf: (usize, usize),
    inf: (usize, usize),
    vf: (usize, usize),
    /// Index of the first pointer card among the lines.
    start: usize,
}

/// The four header lines: card counts, matrix type and sizes (a square
/// `RSA` or `RUA` matrix), and the Fortran formats of the data cards.
fn parse_header(lines: &[&str]) -> Result<Header, FeError> {
    if lines.len() < 4 {
        return fail(
            lines.len().max(1),
            "a Harwell-Boeing file has at least 4 header lines",
        );
    }
    let cards = header_ints(lines[1], 4, 2, "card counts TOTCRD PTRCRD INDCRD VALCRD")?;
    let rhscrd = lines[1]
        .split_whitespace()
        .nth(4)
        .and_then(|t| t.parse::<usize>().ok())
        .unwrap_or(0);
    let (ptrcrd, indcrd, valcrd) = (cards[1], cards[2], cards[3]);
    let mxtype = lines[2].get(..3).unwrap_or("").to_ascii_uppercase();
    let sizes = header_ints(lines[2].get(3..).unwrap_or(""), 3, 3, "NROW NCOL NNZERO")?;
    let (nrow, ncol, nnz) = (sizes[0], sizes[1], sizes[2]);
    let symmetric = match mxtype.as_str() {
        "RSA" => true,
        "RUA" => false,
        other => {
            return fail(
                3,
                format!("matrix type `{other}`: only real assembled RSA or RUA matrices are read"),
            )
        }
    };
    if nrow != ncol {
        return fail(3, format!("matrix is {nrow}×{ncol}, expected square"));
    }
    let (Some(n_ptr), Some(nnz_end)) = (ncol.checked_add(1), nnz.checked_add(1)) else {
        return fail(3, "NCOL or NNZERO is too large");
    };
    let l4 = lines[3];
    let cut = |a: usize, b: usize| l4.get(a..b.min(l4.len())).unwrap_or("");
    let (pf, inf, vf) = if l4.len() >= 33 && l4.starts_with('(') && cut(16, 17) == "(" {
        (cut(0, 16), cut(16, 32), cut(32, 52))
    } else {
        let t: Vec<&str> = l4.split_whitespace().collect();
        (
            t.first().copied().unwrap_or(""),
            t.get(1).copied().unwrap_or(""),
            t.get(2).copied().unwrap_or(""),
        )
    };
    let fmt = |f: &str, what: &str| {
        format_width(f).ok_or_else(|| FeError {
            line: 4,
            message: format!(
                "{what} format `{}` is not a Fortran edit descriptor like (10I8)",
                f.trim()
            ),
        })
    };
    let (pf, inf, vf) = (fmt(pf, "pointer")?, fmt(inf, "index")?, fmt(vf, "value")?);
    let start: usize = if rhscrd > 0 { 5 } else { 4 };
    Ok(Header {
        ptrcrd,
        indcrd,
        valcrd,
        nrow,
        ncol,
        nnz,
        n_ptr,
        nnz_end,
        symmetric,
        pf,
        inf,
        vf,
        start,
    })
}

/// Whether the header's counts can hold: the pointers (from `h.start`),
/// indices (from `ind_start`) and values (from `val_start`) each fit in
/// their cards, and the matrix in memory.
fn check_sizes(
    lines: &[&str],
    h: &Header,
    ind_start: usize,
    val_start: usize,
) -> Result<(), FeError> {
    let Header {
        ptrcrd,
        indcrd,
        valcrd,
        nrow,
        ncol,
        nnz,
        n_ptr,
        symmetric,
        pf,
        inf,
        vf,
        start,
        ..
    } = *h;
    // Sizes against the cards that follow, then against the memory limit,
    // before any of them is read.
    for (at, cards, (count, _), wanted, what) in [
        (start, ptrcrd, pf, n_ptr, "column pointers"),
        (ind_start, indcrd, inf, nnz, "row indices"),
        (val_start, valcrd, vf, nnz, "values"),
    ] {
        let available = cards.min(lines.len().saturating_sub(at));
        if wanted > available.saturating_mul(count) {
            return fail(
                3,
                format!(
                    "NCOL {ncol} / NNZERO {nnz}: {wanted} {what} cannot fit in the {available} \
                     card(s) of at most {count} fields that follow; the header is wrong or the \
                     file is truncated"
                ),
            );
        }
    }
    check_size(
        3,
        nrow,
        if symmetric {
            nnz.saturating_mul(2)
        } else {
            nnz
        },
    )
}

/// The matrix entries (0-based row, column, value) from the column
/// pointers, row indices and values read, an `RSA` triangle mirrored;
/// pointers must rise from 1 to NNZERO + 1 and rows lie in 1..=NROW.
fn assemble_entries(
    h: &Header,
    ptr: &[(usize, &str)],
    ind: &[(usize, &str)],
    val: &[(usize, &str)],
) -> Result<Vec<(usize, usize, f64)>, FeError> {
    let (nrow, nnz_end, symmetric, start) = (h.nrow, h.nnz_end, h.symmetric, h.start);
    let int = |(line, f): &(usize, &str), what: &str| {
        f.parse::<usize>()
            .or_else(|_| fail(*line, format!("{what} `{f}` is not a positive integer")))
    };
    let mut pointers = Vec::new();
    for p in ptr {
        pointers.push(int(p, "column pointer")?);
    }
    if pointers.first() != Some(&1)
        || pointers.last() != Some(&nnz_end)
        || pointers.windows(2).any(|w| w[1] < w[0])
    {
        return fail(
            ptr.first().map_or(start + 1, |p| p.0),
            format!("column pointers must rise from 1 to NNZERO + 1 = {nnz_end}"),
        );
    }
    let mut entries = Vec::new();
    for (j, w) in pointers.windows(2).enumerate() {
        for k in w[0] - 1..w[1] - 1 {
            let (Some(at), Some(&(line, f))) = (ind.get(k), val.get(k)) else {
                return fail(
                    ptr.get(j).map_or(1, |p| p.0),
                    "column pointer beyond NNZERO",
                );
            };
            let i = int(at, "row index")?;
            if i == 0 || i > nrow {
                return fail(
                    at.0,
                    format!(
                        "row index {i} of column {} is outside 1..={nrow}; fix the index or NROW",
                        j + 1
                    ),
                );
            }
            let v = parse_real(f).ok_or_else(|| FeError {
                line,
                message: format!("value `{f}` is not a finite number"),
            })?;
            entries.push((i - 1, j, v));
            if symmetric && i - 1 != j {
                entries.push((j, i - 1, v));
            }
        }
    }
    Ok(entries)
}

/// Read an ANSYS `.MAPPING` file (`Matrix Eqn  Node  DOF` lines, DOF one
/// of UX UY UZ ROTX ROTY ROTZ): the label of every equation, in order.
pub fn read_ansys_mapping(text: &str) -> Result<Vec<DofLabel>, FeError> {
    let mut out: Vec<Option<DofLabel>> = Vec::new();
    // Every equation has its own line, so none is numbered beyond the
    // line count: the bound before the table grows to an equation number.
    let most = text.lines().count();
    for (k, line) in text.lines().enumerate() {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.is_empty() || !t[0].starts_with(|c: char| c.is_ascii_digit()) {
            continue;
        }
        let (Some(eq), Some(node), Some(dof)) = (
            t.first().and_then(|s| s.parse::<usize>().ok()),
            t.get(1).and_then(|s| s.parse::<u64>().ok()),
            t.get(2),
        ) else {
            return fail(k + 1, "expected `equation node DOF`, e.g. `12  4  UY`");
        };
        let code = match dof.to_ascii_uppercase().as_str() {
            "UX" => 1,
            "UY" => 2,
            "UZ" => 3,
            "ROTX" => 4,
            "ROTY" => 5,
            "ROTZ" => 6,
            other => {
                return fail(
                    k + 1,
                    format!("DOF `{other}`: only UX UY UZ ROTX ROTY ROTZ"),
                )
            }
        };
        if eq == 0 {
            return fail(k + 1, "equation numbers start at 1");
        }
        if eq > most {
            return fail(
                k + 1,
                format!(
                    "equation {eq} in a file of {most} lines: every equation needs its own line"
                ),
            );
        }
        if out.len() < eq {
            out.resize(eq, None);
        }
        out[eq - 1] = Some((node, code));
    }
    out.iter()
        .enumerate()
        .map(|(i, l)| {
            l.ok_or_else(|| FeError {
                line: 0,
                message: format!("equation {} has no mapping line", i + 1),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_give_count_and_width() {
        assert_eq!(format_width("(10I8)"), Some((10, 8)));
        assert_eq!(format_width("(1P,4E20.12)"), Some((4, 20)));
        assert_eq!(format_width("(3D25.16)"), Some((3, 25)));
        assert_eq!(format_width("(I10)"), Some((1, 10)));
        assert_eq!(format_width("junk"), None);
    }

    #[test]
    fn touching_fields_are_cut_by_width() {
        let hb = "\
title                                                                   key
             3             1             1             1             0
RUA                        2             2             2             0
(3I8)           (2I8)           (2E10.3)
       1       2       3
       1       2
-1.000E+00-2.000E+00
";
        let m = read_harwell_boeing(hb).unwrap();
        assert_eq!(m.entries, vec![(0, 0, -1.0), (1, 1, -2.0)]);
        // A row index beyond NROW names its line; a NNZERO the cards
        // cannot hold is refused before anything is read.
        let e = read_harwell_boeing(&hb.replace("       1       2\n-1", "       1       3\n-1"))
            .unwrap_err();
        assert_eq!(e.line, 6, "{e}");
        assert!(e.message.contains("row index 3"), "{e}");
        let huge = hb.replace(
            "RUA                        2             2             2",
            "RUA                        2             2 1000000000000",
        );
        let e = read_harwell_boeing(&huge).unwrap_err();
        assert!(e.message.contains("cannot fit"), "{e}");
        let e = read_ansys_mapping("1 10 UX\n1000000000000 10 UY\n").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
    }
}
