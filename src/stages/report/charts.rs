//! Report charts: convergence of each identification (best objective and
//! 1 − mean MAC over model evaluations, from history.csv) and the
//! parameter errors of evaluate stages as grouped bars.

use crate::report::document::Document;
use crate::report::svg::{bars, Plot, Series, PALETTE};
use crate::stages::StageError;
use std::path::PathBuf;

pub fn convergence(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let mut plot = Plot::new("Convergence", "model evaluations [–]", "best objective [–]");
    plot.y_log = true;
    plot.caption = "Best objective over model evaluations per identification (J for black-box strategies, ½‖r‖² of the refinement for guided ones; not comparable between the two)".into();
    // 1 − mean MAC of the best point: one scale for criteria that differ
    // between strategies (J for black-box, the refinement's ½‖r‖² for guided).
    let mut mac = Plot::new("MAC reached", "model evaluations [–]", "1 − mean MAC [–]");
    mac.y_log = true;
    mac.caption = "1 − mean MAC of the best point over model evaluations per identification: one scale for every strategy".into();
    for (k, (stage, path)) in inputs.iter().enumerate() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StageError::io("cannot read input `histories`", e))?;
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').map(|f| f.trim().parse().ok()).collect())
            .collect();
        let column = |c: usize| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((*r.first()?, *r.get(c)?)))
                .collect()
        };
        let colour = PALETTE[k % PALETTE.len()];
        plot.series
            .push(Series::line(stage.clone(), column(1), colour));
        let gap: Vec<(f64, f64)> = column(2)
            .into_iter()
            .map(|(e, m)| (e, (1.0 - m).max(1e-12)))
            .collect();
        if !gap.is_empty() {
            mac.series.push(Series::line(stage.clone(), gap, colour));
        }
    }
    doc.heading(2, "Convergence");
    doc.figure(plot.caption.clone(), "convergence.svg", plot.to_svg());
    if !mac.series.is_empty() {
        doc.figure(mac.caption.clone(), "mac_convergence.svg", mac.to_svg());
    }
    Ok(())
}

pub fn parameter_errors(
    doc: &mut Document,
    inputs: &[(String, PathBuf)],
) -> Result<(), StageError> {
    let mut labels: Vec<String> = Vec::new();
    let mut series = Vec::new();
    for (stage, dir) in inputs {
        let Ok(text) = std::fs::read_to_string(dir.join("parameter_errors.csv")) else {
            continue;
        };
        let mut values = Vec::new();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let (Some(name), Some(rel)) = (f.first(), f.get(3).and_then(|v| v.parse::<f64>().ok()))
            else {
                continue;
            };
            let i = labels.iter().position(|l| l == name).unwrap_or_else(|| {
                labels.push(name.to_string());
                labels.len() - 1
            });
            values.resize(labels.len(), f64::NAN);
            values[i] = 100.0 * rel.abs();
        }
        series.push((stage.clone(), values));
    }
    if series.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Parameter errors");
    let caption = "Absolute relative error |p − p_true|/p_true of each identified parameter per evaluate stage, in percent";
    doc.figure(
        caption,
        "parameter_errors.svg",
        bars(
            "Parameter errors",
            ("parameter", &labels),
            "|relative error| [%]",
            &series,
            caption,
        ),
    );
    Ok(())
}
