//! Abaqus matrix output (`*MATRIX GENERATE, STIFFNESS, MASS` with
//! `*MATRIX OUTPUT, FORMAT=COORDINATE`, files `<job>_STIF1.mtx`,
//! `<job>_MASS1.mtx`; Abaqus Keywords Reference, "*MATRIX OUTPUT"): one
//! entry per line, `row node, row DOF, column node, column DOF, value`,
//! comma-separated, one triangle of a symmetric matrix. Rows are numbered
//! by (node, DOF) in ascending order; the labels come with the matrix. Lines
//! of three numbers (`row, column, value`, 1-based) are read as unlabelled
//! coordinates; `**` lines are comments.

use super::{check_size, fail, number_labels, parse_real, DofLabel, FeError, FeMatrix};

fn dof(field: &str, line: usize) -> Result<u8, FeError> {
    match field.trim().parse::<u8>() {
        Ok(d @ 1..=6) => Ok(d),
        _ => fail(
            line,
            format!(
                "DOF `{}`: only 1..6 (x y z rx ry rz) are read",
                field.trim()
            ),
        ),
    }
}

fn node(field: &str, line: usize) -> Result<u64, FeError> {
    field.trim().parse::<u64>().or_else(|_| {
        fail(
            line,
            format!(
                "node label `{}` is not a non-negative integer",
                field.trim()
            ),
        )
    })
}

/// Read an Abaqus coordinate-format `.mtx` file.
pub fn read_abaqus_mtx(text: &str) -> Result<FeMatrix, FeError> {
    let mut labelled: Vec<(DofLabel, DofLabel, f64)> = Vec::new();
    let mut plain: Vec<(usize, usize, f64)> = Vec::new();
    let mut plain_lines: Vec<usize> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with("**") {
            continue;
        }
        let f: Vec<&str> = t.split(',').collect();
        let value = |s: &str| {
            parse_real(s).ok_or_else(|| FeError {
                line,
                message: format!("value `{}` is not a finite number", s.trim()),
            })
        };
        match f.len() {
            5 => labelled.push((
                (node(f[0], line)?, dof(f[1], line)?),
                (node(f[2], line)?, dof(f[3], line)?),
                value(f[4])?,
            )),
            3 => {
                let idx = |s: &str| match s.trim().parse::<usize>() {
                    Ok(i) if i >= 1 => Ok(i - 1),
                    _ => fail(
                        line,
                        format!("index `{}` is not a 1-based integer", s.trim()),
                    ),
                };
                plain.push((idx(f[0])?, idx(f[1])?, value(f[2])?));
                plain_lines.push(line);
            }
            n => {
                return fail(
                    line,
                    format!(
                        "{n} fields: expected `node, dof, node, dof, value` (FORMAT=COORDINATE)"
                    ),
                )
            }
        }
        if !labelled.is_empty() && !plain.is_empty() {
            return fail(line, "labelled (5-field) and plain (3-field) lines mixed");
        }
    }
    if labelled.is_empty() && plain.is_empty() {
        return fail(1, "no matrix entries");
    }
    if !labelled.is_empty() {
        let lower = labelled.iter().all(|(a, b, _)| a >= b);
        let upper = labelled.iter().all(|(a, b, _)| a <= b);
        return Ok(number_labels(labelled, lower || upper));
    }
    // The size comes from the largest index: bound it before the matrix
    // of that size is built.
    let (n, at) = plain
        .iter()
        .zip(&plain_lines)
        .map(|(&(i, j, _), &line)| (i.max(j).saturating_add(1), line))
        .max_by_key(|&(n, _)| n)
        .unwrap_or((0, 1));
    check_size(at, n, plain.len().saturating_mul(2))?;
    let one = plain.iter().all(|(i, j, _)| i >= j) || plain.iter().all(|(i, j, _)| i <= j);
    let mut entries = plain.clone();
    if one {
        entries.extend(
            plain
                .iter()
                .filter(|(i, j, _)| i != j)
                .map(|&(i, j, v)| (j, i, v)),
        );
    }
    Ok(FeMatrix {
        n,
        entries,
        labels: None,
    })
}
