//! Super-element matrices as FE software exports them: Harwell–Boeing
//! (ANSYS `HBMAT`, with its optional `.MAPPING` file of equation → node and
//! DOF), Abaqus `*MATRIX OUTPUT, FORMAT=COORDINATE` (`.mtx` lines
//! `node, dof, node, dof, value`), Nastran DMIG bulk entries from a punch
//! file (small, large and free field), and Matrix Market. Every reader
//! takes text and returns a [`FeMatrix`] (0-based triplets, both triangles
//! of a symmetric matrix) with the node/DOF label of every row where the
//! format carries one, or an [`FeError`] with the line and what to fix.
//! Nothing here panics on input or touches the file system, and no size
//! read from a header is allocated before `check_size` has bounded it by
//! the file and the memory limit (`--max-memory`).

pub mod abaqus;
pub mod dmig;
pub mod harwell_boeing;
pub mod matrix_market;

pub use abaqus::read_abaqus_mtx;
pub use dmig::read_dmig;
pub use harwell_boeing::{read_ansys_mapping, read_harwell_boeing};
pub use matrix_market::read_matrix_market;

/// A node id and a DOF code 1..=6 (x, y, z, rx, ry, rz).
pub type DofLabel = (u64, u8);

/// A square matrix read from an FE export.
#[derive(Debug, Clone, PartialEq)]
pub struct FeMatrix {
    pub n: usize,
    /// (row, column, value), 0-based, duplicates to be summed.
    pub entries: Vec<(usize, usize, f64)>,
    /// Label of every row, if the file carries node/DOF labels.
    pub labels: Option<Vec<DofLabel>>,
}

/// A malformed file: the 1-based line and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct FeError {
    pub line: usize,
    pub message: String,
}

pub(crate) fn fail<T>(line: usize, message: impl Into<String>) -> Result<T, FeError> {
    Err(FeError {
        line,
        message: message.into(),
    })
}

/// Estimated bytes per matrix row of a super-element once loaded and
/// assembled: column pointers of M and K in the body and again in the
/// assembled model, damping, and the row's DOF label.
pub const BYTES_PER_DOF: f64 = 96.0;

/// Estimated bytes per stored matrix entry once loaded and assembled:
/// triplets (24 bytes) and compressed entries (16) in the body and again in
/// the assembled model.
pub const BYTES_PER_ENTRY: f64 = 80.0;

/// Estimated memory of a loaded matrix of `n` rows and `entries` stored
/// entries (both triangles of a symmetric one).
pub fn matrix_bytes(n: usize, entries: usize) -> f64 {
    n as f64 * BYTES_PER_DOF + entries as f64 * BYTES_PER_ENTRY
}

/// `n` rows and `entries` stored entries read from a header at `line`,
/// checked against the memory limit before anything is allocated for them.
pub(crate) fn check_size(line: usize, n: usize, entries: usize) -> Result<(), FeError> {
    match crate::io::limits::over_memory_limit(matrix_bytes(n, entries)) {
        None => Ok(()),
        Some((needed, limit)) => fail(
            line,
            format!(
                "{n} rows and {entries} entries need an estimated {needed} once loaded, more \
                 than the memory limit of {limit}; the size in the file is wrong, or raise the \
                 limit with --max-memory"
            ),
        ),
    }
}

/// A real number in Fortran/Nastran notation: `1.5E+3`, `1.5D+3`, and
/// Nastran's exponent without `E` (`1.5+3`, `-2.-4`).
pub(crate) fn parse_real(field: &str) -> Option<f64> {
    let s = field.trim().replace(['D', 'd'], "E");
    if s.is_empty() {
        return None;
    }
    if let Ok(v) = s.parse::<f64>() {
        return v.is_finite().then_some(v);
    }
    // Nastran short form: a sign inside the number starts the exponent.
    let b = s.as_bytes();
    let pos = (1..b.len())
        .rev()
        .find(|&i| (b[i] == b'+' || b[i] == b'-') && b[i - 1] != b'E' && b[i - 1] != b'e')?;
    let v: f64 = format!("{}E{}", &s[..pos], &s[pos..]).parse().ok()?;
    v.is_finite().then_some(v)
}

/// Number the labels that occur in `entries` (sorted by node, then DOF)
/// and rewrite labelled triplets to row numbers; a symmetric triangle is
/// mirrored. Used by the labelled formats (Abaqus, DMIG).
pub(crate) fn number_labels(
    labelled: Vec<(DofLabel, DofLabel, f64)>,
    one_triangle: bool,
) -> FeMatrix {
    let mut labels: Vec<DofLabel> = labelled.iter().flat_map(|(a, b, _)| [*a, *b]).collect();
    labels.sort_unstable();
    labels.dedup();
    let index = |l: &DofLabel| labels.binary_search(l).unwrap_or(0);
    let mut entries = Vec::with_capacity(2 * labelled.len());
    for (a, b, v) in &labelled {
        let (i, j) = (index(a), index(b));
        entries.push((i, j, *v));
        if one_triangle && i != j {
            entries.push((j, i, *v));
        }
    }
    FeMatrix {
        n: labels.len(),
        entries,
        labels: Some(labels),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_and_nastran_reals() {
        assert_eq!(parse_real("1.5E+3"), Some(1500.0));
        assert_eq!(parse_real(" 1.5D+03 "), Some(1500.0));
        assert_eq!(parse_real("1.5+3"), Some(1500.0));
        assert_eq!(parse_real("-2.-4"), Some(-2e-4));
        assert_eq!(parse_real("7"), Some(7.0));
        assert_eq!(parse_real("abc"), None);
        assert_eq!(parse_real(""), None);
    }
}
