//! Bounds on what a reader may allocate. A count read from a file (points
//! of a dataset 58, entries and rows of an FE matrix) is first checked
//! against what the bytes that follow could hold, then against the memory
//! limit of [`crate::resources`] (`--max-memory`), before any buffer is
//! made; buffers then grow as values are actually read.

/// Bytes held per value of a dataset 58 while it is imported: the record 12
/// values, their split into abscissa and ordinate, and the FRF set built
/// from them.
pub(crate) const BYTES_PER_UFF_VALUE: f64 = 24.0;

/// Bytes held per CSV FRF cell while the table is read: the cell as
/// `Option<Complex64>` plus its share of the coherence and the set built
/// from it.
pub(crate) const BYTES_PER_CSV_CELL: f64 = 48.0;

/// `(needed, limit)` as human-readable sizes when `bytes` exceed the memory
/// limit, `None` when they fit.
pub(crate) fn over_memory_limit(bytes: f64) -> Option<(String, String)> {
    let limit = crate::resources::memory_limit() as f64;
    // NaN (never expected) counts as over the limit.
    if bytes <= limit {
        return None;
    }
    Some((
        crate::resources::human(bytes),
        crate::resources::human(limit),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_above_the_limit_are_named() {
        assert!(over_memory_limit(1.0).is_none());
        let (needed, limit) = over_memory_limit(1e30).unwrap();
        assert!(needed.ends_with("EiB") && !limit.is_empty(), "{needed}");
        assert!(over_memory_limit(f64::NAN).is_some());
    }
}
