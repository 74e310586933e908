//! FRF comparison of the evaluate kind: FRAC and CSF (eq. 2.66–2.67) of
//! every channel the candidate shares with the reference, on their common
//! frequency lines, with overlays (reference, optional initial model,
//! candidate) per position. Writes `frac.csv` and `frf_<position>.svg`.

use super::schema::{mean, FrfMetrics, PositionFrf};
use super::write;
use crate::frf::FrfSet;
use crate::metrics;
use crate::report::svg::{Plot, Series, PALETTE};
use crate::stages::StageError;
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::Path;

/// Index in `of` of each of the `lines` (exact match), or `None` when one
/// is missing.
fn line_indices(of: &[f64], lines: &[f64]) -> Option<Vec<usize>> {
    lines
        .iter()
        .map(|f| of.iter().position(|g| g == f))
        .collect()
}

/// Compare the FRFs of every reference position with the candidate's.
pub fn compare_frfs(
    reference: &[FrfSet],
    candidate: &[FrfSet],
    initial: Option<&[FrfSet]>,
    tables: &Path,
    plots: &Path,
) -> Result<FrfMetrics, StageError> {
    let mut csv = String::from("position,response,reference,FRAC,CSF\n");
    let mut positions = Vec::new();
    let (mut all_frac, mut all_csf) = (Vec::new(), Vec::new());
    let (mut init_frac, mut init_csf) = (Vec::new(), Vec::new());
    for r in reference {
        let Some(c) = candidate
            .iter()
            .find(|c| c.position.index == r.position.index)
        else {
            continue;
        };
        // Compare on the reference lines the candidate also has (exact match).
        let lines: Vec<(usize, usize)> = r
            .frequencies_hz
            .iter()
            .enumerate()
            .filter_map(|(i, f)| c.frequencies_hz.iter().position(|g| g == f).map(|j| (i, j)))
            .collect();
        if lines.is_empty() {
            return Err(StageError::InvalidInput {
                input: "candidate_frf".into(),
                message: format!(
                    "position {}: no frequency line in common with the reference",
                    r.position.index
                ),
            });
        }
        let (mut fracs, mut csfs) = (Vec::new(), Vec::new());
        let mut plot = Plot::new(
            &format!(
                "FRF overlay, position {} {}",
                r.position.index, r.position.label
            ),
            "frequency [Hz]",
            "|H|",
        );
        plot.y_log = true;
        let f: Vec<f64> = lines.iter().map(|&(i, _)| r.frequencies_hz[i]).collect();
        // The initial model's FRFs of this position, on the compared lines.
        let initial_set = initial
            .and_then(|sets| sets.iter().find(|s| s.position.index == r.position.index))
            .and_then(|s| line_indices(&s.frequencies_hz, &f).map(|idx| (s, idx)));
        for ch in &r.channels {
            let Some(cc) = c.channel(ch.response, ch.reference) else {
                continue;
            };
            let a: Vec<Complex64> = lines.iter().map(|&(i, _)| ch.values[i]).collect();
            let b: Vec<Complex64> = lines.iter().map(|&(_, j)| cc.values[j]).collect();
            let (fr, cs) = (metrics::frac(&a, &b), metrics::csf(&a, &b));
            let _ = writeln!(
                csv,
                "{},{},{},{fr},{cs}",
                r.position.index, ch.response, ch.reference
            );
            let before: Option<Vec<Complex64>> = initial_set.as_ref().and_then(|(s, idx)| {
                let c0 = s.channel(ch.response, ch.reference)?;
                Some(idx.iter().map(|&j| c0.values[j]).collect())
            });
            if let Some(h0) = &before {
                init_frac.push(metrics::frac(&a, h0));
                init_csf.push(metrics::csf(&a, h0));
            }
            // Up to three channels as reference/candidate pairs, or two as
            // reference/initial/candidate triples.
            let per = if initial.is_some() { 3 } else { 2 };
            if plot.series.len() + per <= 6 {
                let k = plot.series.len() / per;
                let curve =
                    |h: &[Complex64]| f.iter().zip(h).map(|(f, h)| (*f, h.norm())).collect();
                let name = |what: &str| format!("{}/{} {what}", ch.response, ch.reference);
                plot.series
                    .push(Series::line(name("reference"), curve(&a), PALETTE[per * k]));
                if let Some(h0) = &before {
                    plot.series.push(Series::line(
                        name("initial"),
                        curve(h0),
                        PALETTE[per * k + 2],
                    ));
                }
                plot.series.push(Series::line(
                    name("candidate"),
                    curve(&b),
                    PALETTE[per * k + 1],
                ));
            }
            fracs.push(fr);
            csfs.push(cs);
        }
        write(
            &plots.join(format!("frf_{}.svg", r.position.index)),
            plot.to_svg(),
        )?;
        positions.push(PositionFrf {
            position: r.position.index,
            label: r.position.label.clone(),
            channels: fracs.len(),
            mean_frac: mean(&fracs),
            mean_csf: mean(&csfs),
        });
        all_frac.extend(fracs);
        all_csf.extend(csfs);
    }
    write(&tables.join("frac.csv"), &csv)?;
    Ok(FrfMetrics {
        channels: all_frac.len(),
        mean_frac: mean(&all_frac),
        mean_csf: mean(&all_csf),
        positions,
        initial_mean_frac: initial.and(mean(&init_frac)),
        initial_mean_csf: initial.and(mean(&init_csf)),
    })
}
