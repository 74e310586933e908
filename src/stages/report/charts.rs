//! Report charts: convergence of each identification (best objective and
//! 1 − mean MAC over model evaluations, from history.csv) and the
//! parameter errors of evaluate stages as grouped bars.

use crate::report::document::Document;
use crate::report::svg::{bars, Plot, Series, PALETTE};
use crate::stages::StageError;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Bars a parameter chart shows; the rest are summarized under it.
pub const TOP_BARS: usize = 20;

/// The best-so-far value as a staircase over evaluations: each
/// improvement a step, held flat to `total` evaluations (the run's count)
/// after the last one, so every curve spans the whole run.
fn staircase(points: &[(f64, f64)], total: Option<f64>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(2 * points.len() + 1);
    for &(e, v) in points {
        if let Some(&(_, prev)) = out.last() {
            out.push((e, prev));
        }
        out.push((e, v));
    }
    if let (Some(&(e, v)), Some(t)) = (out.last(), total) {
        if t > e {
            out.push((t, v));
        }
    }
    out
}

/// The rows of a history.csv, each cell a number or NaN (an empty cell,
/// e.g. a mean MAC not computed, must not drop the row).
fn history_rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|f| f.trim().parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect()
}

/// Convergence figures of the `histories`; `totals` are the evaluations
/// each stage used (from its cost.json), where the curves end.
pub fn convergence(
    doc: &mut Document,
    inputs: &[(String, PathBuf)],
    totals: &BTreeMap<String, usize>,
) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let mut plot = Plot::new("Convergence", "model evaluations [–]", "best objective [–]");
    plot.y_log = true;
    plot.caption = "Best objective so far over model evaluations per identification, to the last evaluation of each run (J for black-box strategies, ½‖r‖² of the refinement for guided ones; not comparable between the two)".into();
    // 1 − mean MAC of the best point: one scale for criteria that differ
    // between strategies (J for black-box, the refinement's ½‖r‖² for guided).
    let mut mac = Plot::new("MAC reached", "model evaluations [–]", "1 − mean MAC [–]");
    mac.y_log = true;
    mac.caption = "1 − mean MAC of the best point so far over model evaluations per identification, to the last evaluation of each run: one scale for every strategy".into();
    for (k, (stage, path)) in inputs.iter().enumerate() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StageError::io("cannot read input `histories`", e))?;
        let rows = history_rows(&text);
        let column = |c: usize| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((*r.first()?, *r.get(c)?)))
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect()
        };
        let total = totals.get(stage).map(|&n| n as f64);
        let colour = PALETTE[k % PALETTE.len()];
        plot.series.push(Series::line(
            stage.clone(),
            staircase(&column(1), total),
            colour,
        ));
        let gap: Vec<(f64, f64)> = column(2)
            .into_iter()
            .map(|(e, m)| (e, (1.0 - m).max(1e-12)))
            .collect();
        if !gap.is_empty() {
            mac.series
                .push(Series::line(stage.clone(), staircase(&gap, total), colour));
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
    for (_, v) in &mut series {
        v.resize(labels.len(), f64::NAN);
    }
    // Largest error (over the stages) first; the top TOP_BARS drawn.
    let worst = |i: usize| {
        series
            .iter()
            .map(|(_, v)| v[i])
            .filter(|x| x.is_finite())
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by(|&a, &b| worst(b).total_cmp(&worst(a)));
    let shown: Vec<usize> = order.iter().copied().take(TOP_BARS).collect();
    let rest: Vec<f64> = order.iter().skip(TOP_BARS).map(|&i| worst(i)).collect();
    let top_labels: Vec<String> = shown.iter().map(|&i| labels[i].clone()).collect();
    let top_series: Vec<(String, Vec<f64>)> = series
        .iter()
        .map(|(n, v)| (n.clone(), shown.iter().map(|&i| v[i]).collect()))
        .collect();
    doc.heading(2, "Parameter errors");
    let caption = format!(
        "Absolute relative error |p − p_true|/p_true per evaluate stage, in percent: the {} parameters with the largest error (of any stage), largest first",
        top_labels.len()
    );
    doc.figure(
        caption.clone(),
        "parameter_errors.svg",
        bars(
            "Parameter errors (largest first)",
            ("parameter", &top_labels),
            "|relative error| [%]",
            &top_series,
            &caption,
        ),
    );
    if let (Some(&hi), false) = (rest.first(), rest.is_empty()) {
        let lo = rest.iter().copied().fold(f64::INFINITY, f64::min);
        doc.paragraph(format!(
            "The other {} parameters (not drawn): largest error of any stage between {} % and {} %.",
            rest.len(),
            crate::report::format::sig(lo.max(0.0), 3),
            crate::report::format::sig(hi, 3)
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{history_rows, parameter_errors, staircase, TOP_BARS};
    use crate::report::document::{Block, Document};

    #[test]
    fn a_large_parameter_chart_shows_the_largest_errors_sorted() {
        let dir = std::env::temp_dir().join(format!("mf-bars-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut csv = String::from("parameter,truth,estimate,relative_error,log10_ratio\n");
        for k in 0..78 {
            // p77 has the largest error, p0 the smallest.
            let rel = 0.001 * f64::from(k + 1);
            csv.push_str(&format!("p{k},1,{},{rel},0\n", 1.0 + rel));
        }
        std::fs::write(dir.join("parameter_errors.csv"), csv).unwrap();
        let mut doc = Document::new("t");
        parameter_errors(&mut doc, &[("score".into(), dir.clone())]).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let (_, svg) = doc.figures().next().expect("a figure");
        let labels: Vec<&str> = svg
            .split("class=\"category\"")
            .skip(1)
            .filter_map(|t| t.split('>').nth(1)?.split('<').next())
            .collect();
        assert_eq!(labels.len(), TOP_BARS, "{labels:?}");
        assert_eq!(labels[0], "p77", "largest first");
        assert_eq!(labels[TOP_BARS - 1], format!("p{}", 78 - TOP_BARS));
        let rest = doc.blocks.iter().any(|b| {
            matches!(b, Block::Paragraph(t) if t.starts_with(&format!("The other {} parameters", 78 - TOP_BARS)))
        });
        assert!(rest, "the rest summarized");
    }

    #[test]
    fn curves_reach_the_last_evaluation_and_keep_rows_with_gaps() {
        let rows = history_rows("evaluation,best_objective,mean_mac\n1,4,0.5\n10,2,\n630,1,0.9\n");
        assert_eq!(rows.len(), 3, "a row with an empty cell is kept");
        let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r[0], r[1])).collect();
        let s = staircase(&pts, Some(1893.0));
        assert_eq!(s.last(), Some(&(1893.0, 1.0)));
        assert_eq!(s[1], (10.0, 4.0), "held until the next improvement");
        assert_eq!(staircase(&pts, None).last(), Some(&(630.0, 1.0)));
    }
}
