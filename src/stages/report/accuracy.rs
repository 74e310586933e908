//! The accuracy section of a report: one row per evaluate stage (paired,
//! missed and spurious modes, ambiguous pairs, MAC, NFD, NDD, FRAC, CSF,
//! parameter error, the copied verdict), then a box listing every missed
//! reference mode, spurious candidate mode and ambiguous pair by number and
//! frequency, so a mean MAC over fewer modes cannot pass for a full match.

use super::pct;
use super::verdicts::ok_cell;
use crate::artifacts::metrics::{Metrics, ModeRef, PositionModes};
use crate::report::document::{Document, Tone};

pub fn accuracy(doc: &mut Document, inputs: &[(String, Metrics)]) {
    if inputs.is_empty() {
        return;
    }
    let rows = inputs
        .iter()
        .map(|(stage, m)| {
            let modes = m.modes.as_ref();
            let count = |f: fn(&crate::artifacts::metrics::ModeMetrics) -> usize| {
                modes.map_or("–".into(), |x| match f(x) {
                    0 => "0".to_string(),
                    k => format!("✗ {k}"),
                })
            };
            vec![
                stage.clone(),
                modes.map_or("–".into(), |x| {
                    format!("{}/{}", x.paired, x.reference_modes)
                }),
                count(|x| x.unpaired_reference),
                count(|x| x.unpaired_candidate),
                count(|x| x.ambiguous),
                pct(modes.and_then(|x| x.mean_mac)),
                pct(modes.and_then(|x| x.mean_nfd)),
                pct(modes.and_then(|x| x.mean_ndd)),
                pct(m.frf.as_ref().and_then(|f| f.mean_frac)),
                pct(m.frf.as_ref().and_then(|f| f.mean_csf)),
                pct(m
                    .parameters
                    .as_ref()
                    .and_then(|p| p.mean_abs_relative_error)),
                m.verdict.as_ref().map_or("–".into(), ok_cell),
            ]
        })
        .collect();
    doc.heading(2, "Accuracy");
    let header = [
        "stage",
        "paired modes",
        "missed",
        "spurious",
        "ambiguous",
        "MAC %",
        "NFD %",
        "NDD %",
        "FRAC %",
        "CSF %",
        "parameter error %",
        "verdict",
    ];
    doc.table(header.map(String::from).to_vec(), rows);
    per_position(doc, inputs);
    pairing_findings(doc, inputs);
}

/// One row per evaluate stage and position: the pairing and FRF criteria
/// of that position alone, so a good mean cannot hide a bad position.
fn per_position(doc: &mut Document, inputs: &[(String, Metrics)]) {
    let mut rows = Vec::new();
    for (stage, m) in inputs {
        let mut indices: Vec<(u32, String)> = Vec::new();
        if let Some(x) = &m.modes {
            indices.extend(x.positions.iter().map(|p| (p.position, p.label.clone())));
        }
        if let Some(f) = &m.frf {
            for p in &f.positions {
                if !indices.iter().any(|(i, _)| *i == p.position) {
                    indices.push((p.position, p.label.clone()));
                }
            }
        }
        indices.sort();
        for (index, label) in indices {
            let modes = m
                .modes
                .as_ref()
                .and_then(|x| x.positions.iter().find(|p| p.position == index));
            let frf = m
                .frf
                .as_ref()
                .and_then(|x| x.positions.iter().find(|p| p.position == index));
            let count = |n: Option<usize>| match n {
                None => "–".to_string(),
                Some(0) => "0".to_string(),
                Some(k) => format!("✗ {k}"),
            };
            rows.push(vec![
                stage.clone(),
                if label.is_empty() {
                    index.to_string()
                } else {
                    format!("{index} ({label})")
                },
                modes.map_or("–".into(), |p| {
                    format!("{}/{}", p.paired, p.reference_modes)
                }),
                count(modes.map(|p| p.unpaired_reference.len())),
                count(modes.map(|p| p.unpaired_candidate.len())),
                pct(modes.and_then(|p| p.mean_mac)),
                pct(modes.and_then(|p| p.min_mac)),
                pct(modes.and_then(|p| p.mean_nfd)),
                pct(modes.and_then(|p| p.max_nfd)),
                pct(modes.and_then(|p| p.mean_ndd)),
                pct(frf.and_then(|p| p.mean_frac)),
                pct(frf.and_then(|p| p.mean_csf)),
            ]);
        }
    }
    if rows.len() < 2 {
        return;
    }
    doc.heading(3, "Accuracy per position");
    let header = [
        "stage",
        "position",
        "paired",
        "missed",
        "spurious",
        "mean MAC %",
        "min MAC %",
        "mean NFD %",
        "max NFD %",
        "mean NDD %",
        "FRAC %",
        "CSF %",
    ];
    doc.table(header.map(String::from).to_vec(), rows);
}

/// `2 (45.10 Hz), 5 (120.3 Hz)`.
fn modes_text(modes: &[ModeRef]) -> String {
    modes
        .iter()
        .map(|m| format!("{} ({:.4} Hz)", m.mode, m.frequency_hz))
        .collect::<Vec<_>>()
        .join(", ")
}

/// What one position's pairing left over, one line each.
fn position_findings(stage: &str, p: &PositionModes) -> Vec<String> {
    let at = if p.label.is_empty() {
        format!("{stage}, position {}", p.position)
    } else {
        format!("{stage}, position {} ({})", p.position, p.label)
    };
    let mut lines = Vec::new();
    if let Some(e) = &p.error {
        lines.push(format!("{at}: {e}"));
    }
    if !p.unpaired_reference.is_empty() {
        lines.push(format!(
            "{at}: reference mode(s) {} have no candidate partner (missed)",
            modes_text(&p.unpaired_reference)
        ));
    }
    if !p.unpaired_candidate.is_empty() {
        lines.push(format!(
            "{at}: candidate mode(s) {} have no reference partner (spurious, or outside the reference)",
            modes_text(&p.unpaired_candidate)
        ));
    }
    for a in &p.ambiguous {
        let mut rivals = Vec::new();
        if let Some(c) = a.rival_candidate {
            rivals.push(format!("candidate {c}"));
        }
        if let Some(r) = a.rival_reference {
            rivals.push(format!("reference {r}"));
        }
        lines.push(format!(
            "{at}: reference {} ({:.4} Hz) ↔ candidate {} ({:.4} Hz) is ambiguous: margin {:.3}, MAC {:.3}{}",
            a.reference_mode,
            a.reference_hz,
            a.candidate_mode,
            a.candidate_hz,
            a.margin,
            a.mac,
            if rivals.is_empty() {
                String::new()
            } else {
                format!("; rival {}", rivals.join(", "))
            }
        ));
    }
    lines
}

fn pairing_findings(doc: &mut Document, inputs: &[(String, Metrics)]) {
    let lines: Vec<String> = inputs
        .iter()
        .filter_map(|(s, m)| m.modes.as_ref().map(|x| (s, x)))
        .flat_map(|(s, x)| {
            x.positions
                .iter()
                .flat_map(move |p| position_findings(s, p))
        })
        .collect();
    if lines.is_empty() {
        return;
    }
    doc.callout(
        Tone::Warning,
        "Mode pairing: not every mode has a clear partner",
        lines,
    );
}
