//! Reference modes for the `import` kind (`content: modes`): published
//! values, another tool's table or a Test.Lab UFF 55 file become a `modes`
//! artifact, so `evaluate` compares AutoEMA with them.
//!
//! - CSV (`.csv`, or `format: csv`): a `modes.csv` table
//!   (`position,position_label,mode,frequency_hz,damping_ratio`; the
//!   position columns and `damping_ratio` may be left out, a damping cell
//!   left empty means not given) and optionally, under `shapes:`, a
//!   `mode_shapes.csv` table (`position,mode,node,direction,real,imag`).
//! - UFF (anything else): datasets 55 (normal or complex modes, the
//!   reader and writer `export` uses), one position per load case; the file's
//!   nodes (15/2411) and trace lines (82) become the geometry.
//!
//! A damping ratio not given is written as an empty cell; `evaluate` skips
//! NDD and MACXP for such pairs and says so. Modes without shapes are paired
//! by frequency alone. `band` keeps the modes inside it.

use super::{by_extension, read_file, write_json, Format, Params};
use crate::artifacts;
use crate::io;
use crate::modal::ModalModel;
use crate::stages::{StageContext, StageError, StageOutputs};

/// Reads the reference modes `params.path` (and `params.shapes`) names.
pub fn run(params: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
    let files = crate::stages::expand_glob(ctx.pipeline_dir, &params.path).map_err(|message| {
        StageError::InvalidParam {
            param: "path".into(),
            message,
        }
    })?;
    let [(rel, path)] = files.as_slice() else {
        return Err(StageError::InvalidParam {
            param: "path".into(),
            message: format!(
                "`{}` matches {} files; reference modes come from one file",
                params.path,
                files.len()
            ),
        });
    };
    let invalid = |input: &str| {
        let input = input.to_string();
        move |e: io::IoError| StageError::InvalidInput {
            input: input.clone(),
            message: e.to_string(),
        }
    };
    let bytes = read_file(path, rel)?;
    let mut warnings = Vec::new();
    let mut geometry = crate::geometry::Geometry::default();
    let format = params.format.unwrap_or_else(|| by_extension(path));
    let mut models = if format == Format::Csv {
        let (shapes, shapes_rel) = match &params.shapes {
            Some(s) => (read_file(&ctx.pipeline_dir.join(s), s)?, s.clone()),
            None => (Vec::new(), String::new()),
        };
        io::read_modal_csv(&bytes, rel, &shapes, &shapes_rel).map_err(invalid(rel))?
    } else {
        let file = io::read_uff(&bytes, rel).map_err(invalid(rel))?;
        geometry = crate::geometry::Geometry::from_uff(&file).unwrap_or_default();
        let imported = io::modal_models_from_uff(&file, rel).map_err(invalid(rel))?;
        warnings.extend(file.warnings.iter().map(|w| format!("{rel}: {w}")));
        warnings.extend(imported.warnings.iter().map(|w| format!("{rel}: {w}")));
        imported.models
    };
    if let Some(g) = &params.geometry {
        let (g, w) = super::geometry_file::read(ctx, g)?;
        geometry = g;
        warnings.extend(w);
    }
    if let Some((lo, hi)) = params.band {
        for m in &mut models {
            m.modes.retain(|x| (lo..=hi).contains(&x.frequency_hz));
        }
    }
    if models.iter().all(|m| m.modes.is_empty()) {
        return Err(StageError::InvalidInput {
            input: rel.clone(),
            message: "no modes found (UFF: datasets 55 of analysis type 2, 3 or 7; CSV: rows \
                      of modes.csv), or none inside `band`"
                .into(),
        });
    }
    warnings.extend(notes(&models, rel));
    let dir = ctx.scratch.join(artifacts::modes::DIR);
    artifacts::modes::write_modes(&dir, &models)?;
    let summary = serde_json::json!({
        "files": [rel],
        "content": "modes",
        "positions": models.iter().map(|m| serde_json::json!({
            "index": m.position.index,
            "label": m.position.label,
            "modes": m.modes.len(),
            "dofs": m.dofs.len(),
            "damping_given": m.modes.iter().filter(|x| !x.damping_ratio.is_nan()).count(),
        })).collect::<Vec<_>>(),
        "warnings": warnings,
    });
    let summary_path = write_json(ctx, "import.json", &summary)?;
    let geometry_path = write_json(ctx, "geometry.json", &geometry)?;
    let count: usize = models.iter().map(|m| m.modes.len()).sum();
    Ok(StageOutputs {
        warnings,
        files: vec![
            ("modes".into(), dir),
            ("summary".into(), summary_path),
            ("geometry".into(), geometry_path),
        ],
        counters: [
            ("modes".to_string(), count as u64),
            ("positions".to_string(), models.len() as u64),
        ]
        .into(),
    })
}

/// What the user should know about the modes read: damping not given,
/// shapes missing.
fn notes(models: &[ModalModel], rel: &str) -> Vec<String> {
    let mut out = Vec::new();
    let no_damping: usize = models
        .iter()
        .map(|m| m.modes.iter().filter(|x| x.damping_ratio.is_nan()).count())
        .sum();
    if no_damping > 0 {
        out.push(format!(
            "{rel}: {no_damping} mode(s) without a damping ratio (written as empty cells); \
             evaluate skips NDD and MACXP for their pairs"
        ));
    }
    if models.iter().any(|m| m.dofs.is_empty()) {
        out.push(format!(
            "{rel}: modes without shapes; evaluate pairs them by frequency alone (no MAC)"
        ));
    }
    out
}
