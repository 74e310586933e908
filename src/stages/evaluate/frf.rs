//! FRF comparison of the evaluate kind: FRAC and CSF (eq. 2.66–2.67) of
//! every channel the candidate shares with the reference, on their common
//! frequency lines, with overlays (reference, optional initial model,
//! candidate) per position. Writes `frac.csv`, `frf_<position>.svg` (the
//! first channel's magnitude and phase) and `frf_channels_<position>.svg`
//! (every channel's magnitude, small multiples).
//!
//! FRFs are compared in the reference's quantity: a candidate (or initial)
//! set of another quantity is converted by (jω)ⁿ first
//! ([`crate::frf::convert_quantity`]; a 0 Hz line that would be divided by
//! jω is left out), and each conversion is listed in metrics.json, so a
//! receptance model and accelerance measurements compare as they should.

use super::mean;
use super::write;
use crate::artifacts::metrics::{FrfMetrics, PositionFrf};
use crate::frf::{convert_quantity, FrfSet};
use crate::metrics;
use crate::report::svg::{stacked, Plot, Series, PALETTE};
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
    candidate_name: &str,
    tables: &Path,
    plots: &Path,
) -> Result<FrfMetrics, StageError> {
    let mut conversions = Vec::new();
    let mut tally = Tally::new();
    let mut initial_sets = Vec::new();
    for r in reference {
        let Some(c) = in_reference_quantity(candidate, "candidate", r, &mut conversions) else {
            continue;
        };
        if let Some(i) =
            initial.and_then(|sets| in_reference_quantity(sets, "initial", r, &mut conversions))
        {
            initial_sets.push(i);
        }
        let overlay = tally.add_position(r, &c, &initial_sets)?;
        if let Some([one, all]) = overlay.to_svgs(r, initial.is_some(), candidate_name) {
            write(&plots.join(format!("frf_{}.svg", r.position.index)), one)?;
            write(
                &plots.join(format!("frf_channels_{}.svg", r.position.index)),
                all,
            )?;
        }
    }
    write(&tables.join("frac.csv"), &tally.csv)?;
    Ok(FrfMetrics {
        channels: tally.frac.len(),
        mean_frac: mean(&tally.frac),
        mean_csf: mean(&tally.csf),
        positions: tally.positions,
        initial_mean_frac: initial.and(mean(&tally.initial_frac)),
        initial_mean_csf: initial.and(mean(&tally.initial_csf)),
        quantity: reference
            .first()
            .map_or(String::new(), |r| r.quantity.name().to_string()),
        conversions,
    })
}

/// The set of `sets` at reference `r`'s position in `r`'s quantity
/// (`None` when there is none), converted by (jω)ⁿ if need be; each
/// conversion is listed in `conversions` (`what`: whose set it is).
fn in_reference_quantity(
    sets: &[FrfSet],
    what: &str,
    r: &FrfSet,
    conversions: &mut Vec<String>,
) -> Option<FrfSet> {
    let s = sets.iter().find(|s| s.position.index == r.position.index)?;
    if s.quantity == r.quantity {
        return Some(s.clone());
    }
    let (converted, dropped) = convert_quantity(s, r.quantity);
    conversions.push(format!(
        "position {}: {what} {} converted to {} by (jω)^{}{}",
        r.position.index,
        s.quantity.name(),
        r.quantity.name(),
        r.quantity.order() - s.quantity.order(),
        if dropped > 0 {
            format!("; {dropped} line(s) at 0 Hz left out (division by jω)")
        } else {
            String::new()
        }
    ));
    Some(converted)
}

/// The reference lines the candidate also has (exact match): pairs of
/// (index in `r`, index in `c`); none is an error of the candidate input.
fn common_lines(r: &FrfSet, c: &FrfSet) -> Result<Vec<(usize, usize)>, StageError> {
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
    Ok(lines)
}

/// What the comparison gathers over the reference positions: the rows of
/// frac.csv, each position's summary, and every channel's FRAC and CSF of
/// the candidate and of the initial model (eq. 2.66–2.67).
struct Tally {
    csv: String,
    positions: Vec<PositionFrf>,
    frac: Vec<f64>,
    csf: Vec<f64>,
    initial_frac: Vec<f64>,
    initial_csf: Vec<f64>,
}

impl Tally {
    /// Nothing compared yet: frac.csv's header only.
    fn new() -> Tally {
        Tally {
            csv: String::from("position,response,reference,FRAC,CSF\n"),
            positions: Vec::new(),
            frac: Vec::new(),
            csf: Vec::new(),
            initial_frac: Vec::new(),
            initial_csf: Vec::new(),
        }
    }

    /// Compare every channel of reference position `r` with the
    /// candidate's `c` (and the initial model's among `initial_sets`) on
    /// their common lines, adding the results; returns the position's
    /// overlay.
    fn add_position(
        &mut self,
        r: &FrfSet,
        c: &FrfSet,
        initial_sets: &[FrfSet],
    ) -> Result<Overlay, StageError> {
        // Compare on the reference lines the candidate also has (exact match).
        let lines = common_lines(r, c)?;
        let (mut fracs, mut csfs) = (Vec::new(), Vec::new());
        let mut overlay = Overlay::new(r.quantity);
        let f: Vec<f64> = lines.iter().map(|&(i, _)| r.frequencies_hz[i]).collect();
        // The initial model's FRFs of this position, on the compared lines.
        let initial_set = initial_sets
            .iter()
            .find(|s| s.position.index == r.position.index)
            .and_then(|s| line_indices(&s.frequencies_hz, &f).map(|idx| (s, idx)));
        for ch in &r.channels {
            // Same nodes and axes; a transducer of opposite sign flips the FRF.
            let Some((cc, sign)) = c.channel_signed(ch.response, ch.reference) else {
                continue;
            };
            let a: Vec<Complex64> = lines.iter().map(|&(i, _)| ch.values[i]).collect();
            let b: Vec<Complex64> = lines.iter().map(|&(_, j)| cc.values[j] * sign).collect();
            let (fr, cs) = (metrics::frac(&a, &b), metrics::csf(&a, &b));
            let _ = writeln!(
                self.csv,
                "{},{},{},{fr},{cs}",
                r.position.index, ch.response, ch.reference
            );
            let before: Option<Vec<Complex64>> = initial_set.as_ref().and_then(|(s, idx)| {
                let (c0, sign0) = s.channel_signed(ch.response, ch.reference)?;
                Some(idx.iter().map(|&j| c0.values[j] * sign0).collect())
            });
            if let Some(h0) = &before {
                self.initial_frac.push(metrics::frac(&a, h0));
                self.initial_csf.push(metrics::csf(&a, h0));
            }
            overlay.add(
                &format!("{}/{}", ch.response, ch.reference),
                fr,
                &f,
                &a,
                before.as_deref(),
                &b,
            );
            fracs.push(fr);
            csfs.push(cs);
        }
        self.positions.push(PositionFrf {
            position: r.position.index,
            label: r.position.label.clone(),
            channels: fracs.len(),
            mean_frac: mean(&fracs),
            mean_csf: mean(&csfs),
        });
        self.frac.extend(fracs);
        self.csf.extend(csfs);
        Ok(overlay)
    }
}

/// Per position: magnitude and phase of the first channel (style guide
/// rule 5) and every channel's magnitude as small multiples — the
/// reference dashed beneath, the initial model dotted and the candidate
/// solid on top. Titles name the candidate, so the overlays of several
/// evaluate stages in one report differ.
struct Overlay {
    magnitude: Plot,
    phase: Plot,
    first: String,
    multiples: Vec<Plot>,
    y_label: String,
}

/// The series of one channel: reference, initial model, candidate.
fn channel_series(
    f: &[f64],
    reference: &[Complex64],
    initial: Option<&[Complex64]>,
    candidate: &[Complex64],
    g: fn(&Complex64) -> f64,
) -> Vec<Series> {
    let curve = |h: &[Complex64]| -> Vec<(f64, f64)> {
        let mut out: Vec<(f64, f64)> = Vec::with_capacity(h.len());
        for (f, h) in f.iter().zip(h) {
            let v = g(h);
            // A phase wrap (a jump over 180°) breaks the line.
            if out.last().is_some_and(|&(_, u)| (v - u).abs() > 180.0) {
                out.push((*f, f64::NAN));
            }
            out.push((*f, v));
        }
        out
    };
    let mut out = vec![Series::reference("reference", curve(reference))];
    if let Some(h0) = initial {
        let mut s = Series::line("initial model", curve(h0), PALETTE[2]);
        s.dash = Some("2 2".into());
        out.push(s);
    }
    out.push(Series::line("candidate", curve(candidate), PALETTE[0]));
    out
}

impl Overlay {
    fn new(q: crate::frf::FrfQuantity) -> Overlay {
        let y_label = format!("|H| [{}]", q.si_unit());
        let mut magnitude = Plot::new("", "frequency [Hz]", &y_label);
        magnitude.y_log = true;
        magnitude.height = 260.0;
        let mut phase = Plot::new("", "frequency [Hz]", "phase [°]");
        phase.y_fixed = Some((-180.0, 180.0, 90.0));
        phase.height = 140.0;
        Overlay {
            magnitude,
            phase,
            first: String::new(),
            multiples: Vec::new(),
            y_label,
        }
    }

    fn add(
        &mut self,
        name: &str,
        frac: f64,
        f: &[f64],
        reference: &[Complex64],
        initial: Option<&[Complex64]>,
        candidate: &[Complex64],
    ) {
        let mag = |h: &Complex64| h.norm();
        let deg = |h: &Complex64| h.arg().to_degrees();
        if self.multiples.is_empty() {
            self.first = name.to_string();
            self.magnitude.series = channel_series(f, reference, initial, candidate, mag);
            self.phase.series = channel_series(f, reference, initial, candidate, deg);
        }
        let title = format!("{name} · FRAC {}", crate::report::format::sig(frac, 3));
        let mut p = Plot::new(&title, "frequency [Hz]", &self.y_label);
        p.y_log = true;
        p.width = 230.0;
        p.height = 120.0;
        p.series = channel_series(f, reference, initial, candidate, mag);
        self.multiples.push(p);
    }

    /// The first channel's magnitude and phase, and every channel's
    /// magnitude (`None` without channels).
    fn to_svgs(&self, r: &FrfSet, with_initial: bool, candidate: &str) -> Option<[String; 2]> {
        if self.multiples.is_empty() {
            return None;
        }
        let at = if r.position.label.is_empty() {
            format!("position {}", r.position.index)
        } else {
            format!("position {} ({})", r.position.index, r.position.label)
        };
        let lines = format!(
            "the reference (dashed){} and {candidate} (solid) as {} in {}",
            if with_initial {
                ", the initial model (dotted)"
            } else {
                ""
            },
            r.quantity.name(),
            r.quantity.si_unit(),
        );
        let one = stacked(
            &format!("FRF of {candidate}, {at}, channel {}", self.first),
            &format!(
                "FRF, {at}, channel {} (response/reference): magnitude and phase of {lines}",
                self.first
            ),
            &[self.magnitude.clone(), self.phase.clone()],
        );
        let n = self.multiples.len();
        let all = crate::report::svg::small_multiples(
            &format!("All {n} FRF channels of {candidate}, {at}"),
            &format!(
                "Magnitude of every FRF channel (response/reference, with its FRAC), {at}: {lines}; one panel per channel"
            ),
            &self.multiples,
            3,
        );
        Some([one, all])
    }
}
