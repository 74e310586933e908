//! The `geometry` param: the test geometry from a universal file of its
//! own. Test software often exports the nodes and trace lines apart from
//! the measurements (a `coords.unv` beside the FRFs); given, this file's
//! geometry replaces whatever the measurement files hold.

use super::{io, StageContext, StageError};
use crate::geometry::Geometry;

/// Nodes (15/2411) and trace lines (82) of the UFF file `rel` (relative to
/// the pipeline file) with the reader's warnings (skipped datasets); an
/// error naming the file when it has no nodes.
pub(super) fn read(ctx: &StageContext, rel: &str) -> Result<(Geometry, Vec<String>), StageError> {
    let invalid = |message: String| StageError::InvalidInput {
        input: rel.to_string(),
        message,
    };
    let bytes = super::read_file(&ctx.pipeline_dir.join(rel), rel)?;
    let file = io::read_uff(&bytes, rel).map_err(|e| invalid(e.to_string()))?;
    let geometry = Geometry::from_uff(&file).ok_or_else(|| {
        invalid(format!(
            "{rel}: no node coordinates (UFF dataset 15 or 2411); give the file with the \
             test geometry, or drop `geometry` to use the measurement files' own"
        ))
    })?;
    let warnings = file
        .warnings
        .iter()
        .map(|w| format!("{rel}: {w}"))
        .collect();
    Ok((geometry, warnings))
}
