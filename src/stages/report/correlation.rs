//! The mode-correlation section of a report: per identify stage, every
//! reference mode with its nominal-model partner at the start (and how well
//! the sensors see it), whether it was used or excluded and why, and its
//! model partner at the result (from correlation.csv). A used mode without
//! a partner at the result is marked ✗.

use super::sig4;
use crate::artifacts::correlation::{self, CorrelationRow};
use crate::report::document::Document;
use crate::stages::StageError;
use std::path::PathBuf;

fn hz(v: Option<f64>) -> String {
    v.map_or(String::new(), |f| format!(" ({f:.4} Hz)"))
}

fn row_cells(r: &CorrelationRow) -> Vec<String> {
    let used = if r.used && r.reason.is_empty() {
        "yes".to_string()
    } else if r.used {
        format!("yes, {}", r.reason)
    } else if r.reason.is_empty() {
        "no".to_string()
    } else {
        format!("no: {}", r.reason)
    };
    let nominal = if r.nominal_mode.is_empty() {
        "–".to_string()
    } else {
        format!("{}{}", r.nominal_mode, hz(r.nominal_hz))
    };
    let model = match (r.model_mode, r.used) {
        (Some(m), _) => format!("{m}{}", hz(r.model_hz)),
        (None, true) => "✗ unpaired".to_string(),
        (None, false) => "–".to_string(),
    };
    vec![
        r.position.to_string(),
        format!("{} ({:.4} Hz)", r.reference_mode, r.reference_hz),
        used,
        format!("{:.2} % / {:.3}", 100.0 * r.sigma_frequency, r.sigma_shape),
        nominal,
        sig4(r.visibility),
        sig4(r.mac_start),
        sig4(r.margin_start),
        model,
        sig4(r.mac),
        sig4(r.margin),
    ]
}

pub fn correlation(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Mode correlation");
    doc.paragraph(
        "Each reference mode, its partner in the nominal model at the start (visibility: how well the \
         sensors see it; margin: how much worse the next-best pairing is), whether it was used, and its \
         model partner at the result.",
    );
    for (stage, path) in inputs {
        let rows = correlation::read(path).map_err(|e| StageError::InvalidInput {
            input: "correlation".into(),
            message: format!("{stage}: {e}"),
        })?;
        let used = rows.iter().filter(|r| r.used).count();
        let unpaired = rows
            .iter()
            .filter(|r| r.used && r.model_mode.is_none())
            .count();
        doc.heading(3, stage.clone());
        doc.paragraph(format!(
            "{used} of {} reference modes used, {} excluded{}.",
            rows.len(),
            rows.len() - used,
            if unpaired > 0 {
                format!("; ✗ {unpaired} used mode(s) unpaired at the result")
            } else {
                String::new()
            }
        ));
        doc.table(
            [
                "position",
                "reference mode",
                "used",
                "σ_f / σ_s",
                "nominal mode (start)",
                "visibility",
                "MAC start",
                "margin start",
                "model mode (result)",
                "MAC",
                "margin",
            ]
            .map(String::from)
            .to_vec(),
            rows.iter().map(row_cells).collect(),
        );
    }
    Ok(())
}
