//! Mode comparison of the evaluate kind: per position, the MAC matrix on the
//! DOFs both models share, the pairing of reference and candidate modes
//! ([`crate::pairing`]: one assignment on (1 − MAC) + NFD/s_f) with each
//! pair's margin, MACXP, NFD and NDD of the pairs (eq. 2.62–2.65), and what
//! the pairing left over: unpaired reference modes (missed), unpaired
//! candidate modes (spurious) and ambiguous pairs.
//!
//! Writes `pairs.csv` (one row per pair, with `cost`, `margin` and
//! `ambiguous`), `mac.csv`, one MAC heatmap per position (both axes
//! labelled `mode · frequency`) and, with a geometry, the paired modes
//! drawn on the structure side by side (`shapes_<position>.svg`).
//!
//! Imported reference modes may lack what the criteria need: a mode
//! without a damping ratio (NaN, an empty cell) gets no NDD and no MACXP
//! (empty cells in pairs.csv, left out of the means), and modes without
//! shapes are paired by frequency alone (cost NFD/s_f, no MAC, no MAC
//! matrix); `notes` in metrics.json says how many.

use super::write;
use super::{extreme, mean};
use crate::artifacts::metrics::{AmbiguousPair, ModeMetrics, ModeRef, PositionModes};
use crate::geometry::Geometry;
use crate::metrics;
use crate::modal::{ModalModel, SharedShapes};
use crate::pairing::{self, Pair, Pairing};
use crate::report::shapes::{self, Drawn};
use crate::report::svg::heatmap;
use crate::stages::StageError;
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::Path;

const PAIRS_HEADER: &str = "position,reference_mode,candidate_mode,reference_hz,candidate_hz,NFD,reference_damping,candidate_damping,NDD,MAC,MACXP,cost,margin,ambiguous\n";

/// Compare the modes of every reference position with the candidate's.
pub fn compare_modes(
    reference: &[ModalModel],
    candidate: &[ModalModel],
    settings: &Pairing,
    geometry: Option<&dyn Fn(u32) -> Option<Geometry>>,
    vertical: Option<usize>,
    tables: &Path,
    plots: &Path,
) -> Result<ModeMetrics, StageError> {
    let mut pairs_csv = String::from(PAIRS_HEADER);
    let mut mac_csv = String::from("position,reference_mode,candidate_mode,MAC\n");
    let mut positions = Vec::new();
    let (mut all_mac, mut all_nfd, mut all_ndd) = (Vec::new(), Vec::new(), Vec::new());
    let mut notes = Vec::new();
    let mut no_damping = 0;
    for r in reference {
        let Some(c) = candidate
            .iter()
            .find(|c| c.position.index == r.position.index)
        else {
            positions.push(PositionModes {
                position: r.position.index,
                label: r.position.label.clone(),
                reference_modes: r.modes.len(),
                unpaired_reference: mode_refs(r, 0..r.modes.len()),
                error: Some("no candidate modes for this position".into()),
                ..PositionModes::default()
            });
            continue;
        };
        let frequency_only = r.dofs.is_empty() || c.dofs.is_empty();
        let shared = if frequency_only {
            notes.push(format!(
                "{}: modes without shapes, paired by frequency alone (no MAC, no MACXP)",
                position_text(r)
            ));
            unit_shapes(r, c)
        } else {
            r.shared_shapes(c)
        };
        if shared.dofs.is_empty() && !frequency_only {
            return Err(StageError::InvalidInput {
                input: "candidate".into(),
                message: format!(
                    "position {}: no DOF in common with the reference",
                    r.position.index
                ),
            });
        }
        let macs = metrics::mac_matrix(&shared.first, &shared.second);
        if !frequency_only {
            for (i, row) in macs.iter().enumerate() {
                for (j, v) in row.iter().enumerate() {
                    let _ = writeln!(mac_csv, "{},{},{},{v}", r.position.index, i + 1, j + 1);
                }
            }
            mac_heatmap(r, c, &macs, plots)?;
        }
        let p = compare_position(r, c, &shared, &macs, settings);
        no_damping += p.no_damping;
        if let Some(g) = geometry.filter(|_| !frequency_only) {
            if let Some(g) = g(r.position.index) {
                shape_figure(r, c, &p.pairs, (&g, vertical), plots)?;
            }
        }
        for row in &p.rows {
            pairs_csv.push_str(row);
        }
        all_mac.extend(&p.macs);
        all_nfd.extend(&p.nfds);
        all_ndd.extend(&p.ndds);
        positions.push(PositionModes {
            common_dofs: shared.dofs.len(),
            ..p.summary
        });
    }
    if no_damping > 0 {
        notes.push(format!(
            "{no_damping} pair(s) without a damping ratio on one side: no NDD, no MACXP"
        ));
    }
    write(&tables.join("pairs.csv"), &pairs_csv)?;
    write(&tables.join("mac.csv"), &mac_csv)?;
    let total = |f: fn(&PositionModes) -> usize| positions.iter().map(f).sum::<usize>();
    Ok(ModeMetrics {
        paired: all_nfd.len(),
        reference_modes: reference.iter().map(|m| m.modes.len()).sum(),
        candidate_modes: total(|p| p.candidate_modes),
        unpaired_reference: total(|p| p.unpaired_reference.len()),
        unpaired_candidate: total(|p| p.unpaired_candidate.len()),
        ambiguous: total(|p| p.ambiguous.len()),
        mean_mac: mean(&all_mac),
        mean_nfd: mean(&all_nfd),
        mean_ndd: mean(&all_ndd),
        positions,
        notes,
    })
}

/// Shapes for pairing by frequency alone: one shared unit coefficient per
/// mode, so every MAC is 1 and the cost is NFD/s_f (the MACs are not
/// reported).
fn unit_shapes(r: &ModalModel, c: &ModalModel) -> SharedShapes {
    let one = |m: &ModalModel| vec![vec![Complex64::new(1.0, 0.0)]; m.modes.len()];
    SharedShapes {
        first: one(r),
        second: one(c),
        dofs: Vec::new(),
    }
}

/// A number for a CSV cell; empty when not available (NaN).
fn cell(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        x.to_string()
    }
}

/// `ModeRef`s of the modes `indices` (0-based) of `m`.
fn mode_refs(m: &ModalModel, indices: impl Iterator<Item = usize>) -> Vec<ModeRef> {
    indices
        .map(|k| ModeRef {
            mode: k + 1,
            frequency_hz: m.modes[k].frequency_hz,
        })
        .collect()
}

fn mac_heatmap(
    r: &ModalModel,
    c: &ModalModel,
    macs: &[Vec<f64>],
    plots: &Path,
) -> Result<(), StageError> {
    let labels = |m: &ModalModel| {
        m.modes
            .iter()
            .enumerate()
            .map(|(k, m)| format!("{} · {}", k + 1, hz(m.frequency_hz)))
            .collect::<Vec<_>>()
    };
    let (rl, cl) = (labels(r), labels(c));
    let at = position_text(r);
    let svg = heatmap(
        &format!("MAC, {at}"),
        ("reference mode", &rl),
        ("candidate mode", &cl),
        macs,
        (0.0, 1.0),
        &format!(
            "MAC (eq. 2.62) of every reference mode (rows) with every candidate mode (columns), {at}, on the DOFs both share"
        ),
    );
    write(&plots.join(format!("mac_{}.svg", r.position.index)), &svg)
}

/// `position 2 (wpt=0.400)` or `position 2`.
fn position_text(m: &ModalModel) -> String {
    if m.position.label.is_empty() {
        format!("position {}", m.position.index)
    } else {
        format!("position {} ({})", m.position.index, m.position.label)
    }
}

/// A frequency to 4 significant digits with its unit.
fn hz(f: f64) -> String {
    format!("{} Hz", crate::report::format::sig(f, 4))
}

/// A mode to draw with its heading.
fn drawn<'a>(m: &'a ModalModel, k: usize, what: &str, mode: &crate::modal::Mode) -> Drawn<'a> {
    Drawn {
        model: m,
        mode: k,
        heading: format!(
            "{what} mode {} · {} · ζ {}",
            k + 1,
            hz(mode.frequency_hz),
            if mode.damping_ratio.is_nan() {
                "not given".to_string()
            } else {
                format!(
                    "{} %",
                    crate::report::format::sig(100.0 * mode.damping_ratio, 3)
                )
            }
        ),
    }
}

/// The paired modes of one position drawn on the structure: reference and
/// candidate side by side, one pair per row, with the pair's MAC.
fn shape_figure(
    r: &ModalModel,
    c: &ModalModel,
    pairs: &[Pair],
    (g, vertical): (&Geometry, Option<usize>),
    plots: &Path,
) -> Result<(), StageError> {
    let rows: Vec<(Vec<Drawn<'_>>, String)> = pairs
        .iter()
        .map(|p| {
            let (a, b) = (&r.modes[p.reference], &c.modes[p.candidate]);
            (
                vec![
                    drawn(r, p.reference, "reference", a),
                    drawn(c, p.candidate, "candidate", b),
                ],
                format!("MAC {:.3}", p.mac),
            )
        })
        .collect();
    if rows.is_empty() {
        return Ok(());
    }
    let at = position_text(r);
    let svg = shapes::figure(
        &format!("Paired mode shapes, {at}"),
        &format!(
            "Reference (blue) and candidate (orange) mode shapes of every pair, {at}, deformed over the undeformed structure (grey), the candidate sign-aligned with its reference; animated in the HTML report"
        ),
        g,
        vertical,
        &rows,
    );
    write(
        &plots.join(format!("shapes_{}.svg", r.position.index)),
        &svg,
    )
}

/// One position's pairs: its summary (without `common_dofs`), pairs.csv
/// rows and the criteria of its pairs.
struct PositionResult {
    summary: PositionModes,
    pairs: Vec<Pair>,
    rows: Vec<String>,
    macs: Vec<f64>,
    nfds: Vec<f64>,
    ndds: Vec<f64>,
    /// Pairs without a damping ratio on one side.
    no_damping: usize,
}

/// Pairs of one position; `shared.dofs` empty means paired by frequency
/// alone (see [`unit_shapes`]): no MAC, no MACXP.
fn compare_position(
    r: &ModalModel,
    c: &ModalModel,
    shared: &SharedShapes,
    macs: &[Vec<f64>],
    settings: &Pairing,
) -> PositionResult {
    let (rs, cs) = (&shared.first, &shared.second);
    let with_shapes = !shared.dofs.is_empty();
    let rf: Vec<f64> = r.modes.iter().map(|m| m.frequency_hz).collect();
    let cf: Vec<f64> = c.modes.iter().map(|m| m.frequency_hz).collect();
    let costs = pairing::cost_matrix(&rf, &cf, macs, settings);
    let mut pairs = pairing::pair_modes(&rf, rs, &cf, cs, settings);
    if !with_shapes {
        pairs.iter_mut().for_each(|p| p.mac = f64::NAN);
    }
    let margins = pairing::margins(&costs, &pairs);
    let mut out = PositionResult {
        summary: PositionModes::default(),
        pairs: pairs.clone(),
        rows: Vec::new(),
        macs: Vec::new(),
        nfds: Vec::new(),
        ndds: Vec::new(),
        no_damping: 0,
    };
    let mut ambiguous = Vec::new();
    for (p, &margin) in pairs.iter().zip(&margins) {
        let (a, b) = (&r.modes[p.reference], &c.modes[p.candidate]);
        let nfd = metrics::nfd(a.frequency_hz, b.frequency_hz);
        let damped = !(a.damping_ratio.is_nan() || b.damping_ratio.is_nan());
        out.no_damping += usize::from(!damped);
        let ndd = if damped {
            metrics::ndd(a.damping_ratio, b.damping_ratio)
        } else {
            f64::NAN
        };
        let xp = if damped && with_shapes {
            metrics::macxp(
                &rs[p.reference],
                &cs[p.candidate],
                metrics::pole(a.frequency_hz, a.damping_ratio),
                metrics::pole(b.frequency_hz, b.damping_ratio),
            )
        } else {
            f64::NAN
        };
        let is_ambiguous = margin < settings.ambiguity;
        out.rows.push(format!(
            "{},{},{},{},{},{nfd},{},{},{},{},{},{},{margin},{is_ambiguous}\n",
            r.position.index,
            p.reference + 1,
            p.candidate + 1,
            a.frequency_hz,
            b.frequency_hz,
            cell(a.damping_ratio),
            cell(b.damping_ratio),
            cell(ndd),
            cell(p.mac),
            cell(xp),
            p.cost,
        ));
        if is_ambiguous {
            ambiguous.push(ambiguous_pair(p, margin, &costs, &rf, &cf));
        }
        if with_shapes {
            out.macs.push(p.mac);
        }
        out.nfds.push(nfd);
        if damped {
            out.ndds.push(ndd);
        }
    }
    let unpaired_reference: Vec<usize> = (0..r.modes.len())
        .filter(|&k| !pairs.iter().any(|p| p.reference == k))
        .collect();
    let unpaired_candidate: Vec<usize> = (0..c.modes.len())
        .filter(|&k| !pairs.iter().any(|p| p.candidate == k))
        .collect();
    out.summary = PositionModes {
        position: r.position.index,
        label: r.position.label.clone(),
        reference_modes: r.modes.len(),
        candidate_modes: c.modes.len(),
        paired: pairs.len(),
        common_dofs: 0,
        mean_mac: mean(&out.macs),
        min_mac: extreme(&out.macs, f64::min),
        mean_nfd: mean(&out.nfds),
        max_nfd: extreme(&out.nfds, f64::max),
        mean_ndd: mean(&out.ndds),
        unpaired_reference: mode_refs(r, unpaired_reference.into_iter()),
        unpaired_candidate: mode_refs(c, unpaired_candidate.into_iter()),
        ambiguous,
        error: None,
    };
    out
}

/// An ambiguous pair with its rivals: the next-cheapest allowed partner of
/// either mode.
fn ambiguous_pair(
    p: &Pair,
    margin: f64,
    costs: &[Vec<Option<f64>>],
    rf: &[f64],
    cf: &[f64],
) -> AmbiguousPair {
    let cheapest = |options: &mut dyn Iterator<Item = (usize, Option<f64>)>| {
        options
            .filter_map(|(k, c)| c.map(|c| (k, c)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k + 1)
    };
    AmbiguousPair {
        reference_mode: p.reference + 1,
        candidate_mode: p.candidate + 1,
        reference_hz: rf[p.reference],
        candidate_hz: cf[p.candidate],
        mac: p.mac,
        margin,
        rival_candidate: cheapest(
            &mut costs[p.reference]
                .iter()
                .copied()
                .enumerate()
                .filter(|&(j, _)| j != p.candidate),
        ),
        rival_reference: cheapest(
            &mut costs
                .iter()
                .map(|row| row[p.candidate])
                .enumerate()
                .filter(|&(i, _)| i != p.reference),
        ),
    }
}
