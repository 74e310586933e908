//! The assessment of an update at its result: the final pairing with its
//! margins (ambiguous, unpaired and close pairs named), the weighted
//! residual at the start and the result, the identifiability of the
//! identified parameters and the consider analysis of the fixed ones
//! ([`super::consider`]), all from one batch of model evaluations.

use super::batch_means::Correlation;
use super::consider::{ar1_inflation, bounds_spread, consider, Consider};
use super::curvature;
use super::frf_objective::FrfReference;
use super::identifiability::{
    analyze, exact_null_directions, structural_directions, without_directions, Identifiability,
};
use super::joint_effect::{Member, SumCoordinates};
use super::objective::{Match, ModalObjective, ModeSet, SlotPairing};
use super::updating::{FinalPair, Plan};
use super::verdict::{at_edge, DampingJudgement, Implausible, ModeCounts};
use super::IdentifyError;
use crate::numbers::sig;
use crate::optimize::jacobian;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// What [`assess`] finds: (identifiability, consider analysis, its cost in
/// evaluations), the final pairs, (start RMS, end RMS, mode counts) and the
/// close-pair, unpaired-mode and undetermined-in-its-box warnings.
pub(super) type Assessment = (
    (Identifiability, Option<Consider>, usize),
    Vec<Vec<FinalPair>>,
    (f64, f64, ModeCounts),
    Vec<String>,
    Option<DampingJudgement>,
);

/// The final pairing with margins, the weighted-residual RMS at the start
/// and the result, and the identifiability of `identified` at `x`.
pub(super) fn assess(
    o: &ModalObjective,
    start: &[f64],
    x: &[f64],
    identified: &[usize],
    plan: &Plan,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Assessment, IdentifyError> {
    let usable = o.usable();
    let rms = |e: &Option<super::objective::Evaluation>| {
        e.as_ref().map_or(f64::NAN, |e| {
            (2.0 * e.robust_usable / e.count_usable.max(1) as f64).sqrt()
        })
    };
    let at_start = o.evaluate(start, &usable);
    let at_x = o.evaluate(x, &usable);
    let models = o.model_modes(x)?;
    progress(3);
    let matched = o.pair(&models, &usable);
    let mut counts = ModeCounts {
        reference: (0..o.positions()).map(|p| o.modes_at(p)).sum(),
        used: o.reference_modes(),
        ..ModeCounts::default()
    };
    counts.excluded = counts.reference - counts.used;
    let mut pairs = Vec::new();
    let mut close = Vec::new();
    for (p, model) in models.iter().enumerate() {
        let SlotPairing {
            idx,
            rf,
            mf,
            pairs: found,
            margins: m,
            ..
        } = o.pair_with_margins(p, model, &usable);
        let mut slot: Vec<FinalPair> = (0..o.modes_at(p))
            .map(|k| FinalPair {
                matched: matched[p][k],
                margin: f64::INFINITY,
            })
            .collect();
        for (pair, margin) in found.iter().zip(m) {
            slot[idx[pair.reference]].margin = margin;
            if margin < o.pairing.ambiguity {
                counts.ambiguous += 1;
            }
        }
        counts.unpaired += idx.iter().filter(|&&k| matched[p][k].is_none()).count();
        close.extend(unpaired_text(p, &idx, &rf, &matched[p]));
        let weak = weak_pairs(p, &idx, &rf, &matched[p]);
        counts.weak += weak.len();
        close.extend(weak);
        close.extend(unresolved_pairs(p, &mf, &rf, &matched[p]));
        pairs.push(slot);
    }
    let damping = damping_judgement(o, &matched, &usable, identified);
    let frf = plan.frf.map(|(r, _)| r);
    let fixed = fixed_parameters(o, x, identified, plan.fixed_spread);
    let ((mut analysis, mut considered, evaluations), columns) =
        identifiability_at(o, x, identified, &fixed, plan.max_std_error, frf, progress)?;
    // The final intervals are checked against the cost ([`curvature`])
    // where the budget keeps the evaluations for it.
    let checks = super::updating::checks_intervals(o.parameters().len(), plan.budget);
    let checked = if checks {
        curvature::widen(
            o,
            frf,
            x,
            identified,
            &columns,
            (&mut analysis, considered.as_mut()),
            progress,
        )
    } else {
        0
    };
    let p = o.parameters();
    let at = identified.iter().map(|&i| (x[i], (p[i].lower, p[i].upper)));
    close.extend(analysis.spanning_warning(at, considered.as_ref()));
    let identifiability = (analysis, considered, evaluations + checked);
    Ok((
        identifiability,
        pairs,
        (rms(&at_start), rms(&at_x), counts),
        close,
        damping,
    ))
}

/// The damping ratios of the paired used modes against the reference's, when
/// damping parameters are among the `identified` (see [`DampingJudgement`]).
fn damping_judgement(
    o: &ModalObjective,
    matched: &[Vec<Option<Match>>],
    usable: &super::ModeSet,
    identified: &[usize],
) -> Option<DampingJudgement> {
    let dampers: Vec<String> = identified
        .iter()
        .map(|&i| &o.parameters()[i])
        .filter(|p| p.kind == crate::dynamics::ParameterKind::Damping)
        .map(|p| p.name.clone())
        .collect();
    if dampers.is_empty() {
        return None;
    }
    let mut residuals = Vec::new();
    let mut worst = (0.0, String::new());
    for (p, ms) in matched.iter().enumerate() {
        for (k, m) in ms.iter().enumerate() {
            let (Some(m), true) = (m, usable[p][k]) else {
                continue;
            };
            let zr = o.reference_damping(p, k);
            if zr.is_nan() || zr <= 0.0 {
                continue;
            }
            let r = (m.damping_ratio - zr) / (zr * o.reference_damping_sigma(p, k));
            if r.abs() > worst.0 {
                worst = (
                    r.abs(),
                    format!(
                        "position {} mode {} at {} Hz, ζ {} against {}",
                        o.position(p).index,
                        k + 1,
                        sig(o.reference_frequency(p, k), 4),
                        sig(m.damping_ratio, 2),
                        sig(zr, 2)
                    ),
                );
            }
            residuals.push(r);
        }
    }
    DampingJudgement::new(&residuals, worst.1, dampers)
}

/// The used reference modes at position `p` without a model partner at the
/// result, named with their frequencies (`idx`: reference mode numbers,
/// `rf`: their Hz): on real structures these are usually modes the model
/// does not contain (a support or fixture mode, a mode the test added), so
/// they are listed rather than absorbed by the parameters.
fn unpaired_text(p: usize, idx: &[usize], rf: &[f64], matched: &[Option<Match>]) -> Option<String> {
    let names: Vec<String> = idx
        .iter()
        .zip(rf)
        .filter(|(&k, _)| matched.get(k).is_some_and(|m| m.is_none()))
        .map(|(&k, f)| format!("mode {} ({f:.2} Hz)", k + 1))
        .collect();
    (!names.is_empty()).then(|| {
        format!(
            "position {p}: reference {} without a model partner at the result: {} — modes the \
             model does not contain, or spurious estimates; no parameter was fitted to them",
            if names.len() == 1 { "mode" } else { "modes" },
            names.join(", ")
        )
    })
}

/// A final pair this far apart in frequency (relative) *and* below
/// [`WEAK_MAC`] is weak: an updated model reproduces its paired modes within
/// a few per cent at MAC near 1, so both at once say the reference mode is
/// one the model lacks, paired with a neighbour for want of a partner.
const WEAK_NFD: f64 = 0.03;
/// See [`WEAK_NFD`] (MAC, eq. 2.62).
const WEAK_MAC: f64 = 0.8;

/// The weak final pairs at position `p` ([`WEAK_NFD`], [`WEAK_MAC`]), one
/// message each.
fn weak_pairs(p: usize, idx: &[usize], rf: &[f64], matched: &[Option<Match>]) -> Vec<String> {
    idx.iter()
        .zip(rf)
        .filter_map(|(&k, &f)| {
            let m = matched.get(k).copied().flatten()?;
            let d = m.frequency_hz / f - 1.0;
            (d.abs() > WEAK_NFD && m.mac < WEAK_MAC).then(|| {
                format!(
                    "position {p}: reference mode {} ({f:.2} Hz) pairs only weakly, with model mode {} ({:.2} Hz, {:+.1} %, MAC {:.2}): most likely a mode the model does not contain (a fixture, support or test mode); it is counted as not reproduced",
                    k + 1,
                    m.model_mode + 1,
                    m.frequency_hz,
                    100.0 * d,
                    m.mac
                )
            })
        })
        .collect()
}

/// Model modes closer than this (relative frequency) to a paired one are a
/// close pair: with the test bench's ζ ≈ 5 % both lie well inside one
/// half-power bandwidth (2ζ), and an EMA at 1–2 % noise often fits them as
/// one mode.
const CLOSE_PAIR: f64 = 0.03;

/// Warnings for close pairs the reference does not resolve at position
/// `p`: an unpaired model mode (frequencies `mf`) inside the reference's
/// band (`rf`) within [`CLOSE_PAIR`] of a model mode that pairs with a
/// reference mode. The fit cannot see how the pair splits, so neither
/// shape of it is validated by the data.
fn unresolved_pairs(p: usize, mf: &[f64], rf: &[f64], matched: &[Option<Match>]) -> Vec<String> {
    let paired: Vec<(usize, usize)> = matched
        .iter()
        .enumerate()
        .filter_map(|(r, m)| m.map(|m| (m.model_mode, r)))
        .collect();
    let (lo, hi) = rf
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &f| (a.min(f), b.max(f)));
    let mut out = Vec::new();
    for (j, &fj) in mf.iter().enumerate() {
        let inside = fj >= lo * (1.0 - CLOSE_PAIR) && fj <= hi * (1.0 + CLOSE_PAIR);
        if !inside || paired.iter().any(|&(i, _)| i == j) {
            continue;
        }
        let nearest = paired
            .iter()
            .map(|&(i, r)| (i, r, (fj / mf[i] - 1.0).abs()))
            .filter(|&(_, _, d)| d < CLOSE_PAIR)
            .min_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((i, r, d)) = nearest {
            out.push(format!(
                "position {p}: model mode {} ({fj:.2} Hz) lies {:.1} % from model mode {} ({:.2} Hz), which pairs with reference mode {}; the reference has one mode where the model has two (a close pair the measurement does not resolve), so neither shape of the pair is validated",
                j + 1,
                100.0 * d,
                i + 1,
                mf[i],
                r + 1
            ));
        }
    }
    out
}

/// The identifiability of `identified` at `x` from a central-difference
/// Jacobian of the weighted residuals (frequencies, shapes and damping
/// ratios of the usable modes, and the FRF residuals of `frf` when given)
/// with respect to ln p, and the consider analysis of the `fixed`
/// parameters (index, assumed σ of ln p; [`super::consider`]) from the same
/// Jacobian extended to them: one batch of 2·(identified + fixed)
/// evaluations (+1 at `x`); returned with the Jacobian columns of the identified parameters the
/// analysis rests on (∂r/∂ln θ, structural directions removed).
pub(super) fn identifiability_at(
    o: &ModalObjective,
    x: &[f64],
    identified: &[usize],
    fixed: &[(usize, f64)],
    max_std_error: f64,
    frf: Option<&FrfReference>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<IdentifiabilityAt, IdentifyError> {
    let cols: Vec<usize> = identified
        .iter()
        .copied()
        .chain(fixed.iter().map(|f| f.0))
        .collect();
    let (mut columns, r0, observed) = log_jacobian(o, x, &cols, identified.len(), frf, progress)?;
    let fixed_columns = columns.split_off(identified.len());
    // Directions that change no system matrix are structural, exactly
    // (the data's finite differences need not show them: a close pair's
    // shapes turn fast enough to hide them); the columns lose them first.
    let exact = exact_null_directions(&o.prepared().matrix_derivative_gram(identified, x));
    columns = without_directions(&columns, &exact);
    let observed = without_directions(&observed, &exact);
    // With FRFs, the structural null directions are those of the modal
    // residuals and of what the FRFs are a function of
    // ([`FrfReference::modal_observables`]), not of the FRF residuals'
    // own differences (their error at a sharp peak hides a null direction:
    // two guide shoes that act only through their sum); the data's
    // columns lose those directions exactly.
    if let Some(frf) = frf.filter(|_| !observed.is_empty()) {
        let leading = r0.len() - frf.count();
        let modal: Vec<Vec<f64>> = columns.iter().map(|c| c[..leading].to_vec()).collect();
        let null = structural_directions(&[modal, observed]);
        columns = without_directions(&columns, &null);
    }
    let correlation = correlation(&r0, frf);
    let name = |i: &usize| o.parameters()[*i].name.clone();
    let names: Vec<String> = identified.iter().map(name).collect();
    let fixed_names: Vec<String> = fixed.iter().map(|f| name(&f.0)).collect();
    let spreads: Vec<f64> = fixed.iter().map(|f| f.1).collect();
    // The analysis and the consider analysis of some columns.
    let assess = |columns: &[Vec<f64>]| {
        let analysis = analyze(columns, &r0, &names, max_std_error, &correlation);
        let considered = (!fixed.is_empty()).then(|| {
            consider(
                columns,
                &fixed_columns,
                &r0,
                &fixed_names,
                &spreads,
                analysis.residual_variance.unwrap_or(1.0),
                &correlation,
            )
        });
        (analysis, considered)
    };
    let (mut analysis, considered) = assess(&columns);
    // A structural group's sum, where that is what the data determine,
    // from the same analysis with the sum as a coordinate.
    let members: Vec<Member> = identified
        .iter()
        .map(|&i| {
            let p = &o.parameters()[i];
            Member {
                name: p.name.clone(),
                value: x[i],
                lower: p.lower,
                upper: p.upper,
                kind: p.kind,
            }
        })
        .collect();
    if let Some(sums) = SumCoordinates::of(&analysis, &columns, &members) {
        let (rotated, rotated_considered) = assess(&sums.rotate(&columns));
        sums.attach(&mut analysis, &rotated, rotated_considered.as_ref());
    }
    let considered = considered.map(|c| cut_at_bounds(o, x, fixed, c));
    Ok(((analysis, considered, 2 * cols.len() + 1), columns))
}

/// What [`identifiability_at`] returns.
type IdentifiabilityAt = ((Identifiability, Option<Consider>, usize), Vec<Vec<f64>>);

/// Jacobian columns ∂r/∂ln p, the residuals at the point, and the columns
/// of the FRFs' modal observables (empty without).
type LogJacobian = (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>);

/// The residuals at `x` and their Jacobian columns ∂r/∂ln p for the
/// parameters `cols` (indices), the residuals being the usable modes'
/// weighted ones, their damping ratios' and, when given, `frf`'s; with
/// `frf` also the columns of its modal observables for the first `observe`
/// parameters ([`FrfReference::modal_observables`]; empty without, or when
/// the mode count changes within the stencil). Central differences, except
/// the FRF residuals' columns where the observables are at hand: those by
/// the chain rule through them ([`FrfReference::residual_columns`]). One
/// batch of 2·cols + 1 evaluations. An error when the model cannot be
/// solved at `x`.
fn log_jacobian(
    o: &ModalObjective,
    x: &[f64],
    cols: &[usize],
    observe: usize,
    frf: Option<&FrfReference>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<LogJacobian, IdentifyError> {
    let usable = o.usable();
    let full = o.bounds()?;
    let u = full.to_unit(x);
    // The observables' basis at `x` (none when the model cannot be solved
    // there: the structural test then rests on the data's columns).
    let basis = frf.and_then(|f| f.superposition_basis(o.prepared(), x));
    let sub_u: Vec<f64> = cols.iter().map(|&i| u[i]).collect();
    let unobserved = AtomicBool::new(false);
    // Residuals, then observables, with the coordinates `cols` from `s`.
    let residuals = |points: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        let v: Vec<_> = points
            .par_iter()
            .map(|s| {
                let mut unit = u.clone();
                for (j, &i) in cols.iter().enumerate() {
                    unit[i] = s[j];
                }
                let phys = full.to_physical(&unit);
                let mut p = x.to_vec();
                for &i in cols {
                    p[i] = phys[i];
                }
                let mut r = residuals_at(o, &usable, frf, &p)?;
                if let Some(frf) = frf {
                    if let Some(b) = &basis {
                        // A mode count changed at a point leaves them
                        // unused.
                        let v = frf.modal_observables(o.prepared(), &p, b);
                        if v.is_none() {
                            unobserved.store(true, Ordering::Relaxed);
                        }
                        r.extend(v.unwrap_or_else(|| vec![0.0; b.len]));
                    }
                }
                Some(r)
            })
            .collect();
        progress(points.len() as u64);
        v
    };
    let mut r0 = residuals(std::slice::from_ref(&sub_u))
        .pop()
        .flatten()
        .ok_or_else(|| IdentifyError::Model("the model cannot be solved at the result".into()))?;
    let columns_u = jacobian::central(&residuals, &sub_u, &r0, 1e-4);
    // ∂r/∂ln p = ∂r/∂u · du/d ln p.
    let mut columns: Vec<Vec<f64>> = columns_u
        .into_iter()
        .zip(cols)
        .map(|(col, &i)| {
            let (l, h) = (full.lower()[i], full.upper()[i]);
            let du_dlnp = full.scale()[i].du_dln_x(x[i], l, h);
            col.into_iter().map(|v| v * du_dlnp).collect()
        })
        .collect();
    let observed = match (basis, frf) {
        (Some(b), Some(frf)) if r0.len() >= b.len + frf.count() => {
            let m = r0.len() - b.len;
            let obs0 = r0.split_off(m);
            let mut observed: Vec<Vec<f64>> = columns.iter_mut().map(|c| c.split_off(m)).collect();
            if unobserved.load(Ordering::Relaxed) {
                Vec::new()
            } else {
                // The FRF residuals' columns by the chain rule through the
                // observables, exact where the peaks are sharp
                // ([`FrfReference::residual_columns`]).
                if let Some(tangent) = frf.residual_columns(&obs0, &observed, &b) {
                    let start = m - frf.count();
                    for (c, t) in columns.iter_mut().zip(tangent) {
                        c[start..].copy_from_slice(&t);
                    }
                }
                observed.truncate(observe);
                observed
            }
        }
        _ => Vec::new(),
    };
    Ok((columns, r0, observed))
}

/// The residuals the analysis at a result rests on, at `p`: the `usable`
/// modes' weighted ones, their damping ratios' and, when given, `frf`'s;
/// `None` where the model cannot be solved.
pub(super) fn residuals_at(
    o: &ModalObjective,
    usable: &ModeSet,
    frf: Option<&FrfReference>,
    p: &[f64],
) -> Option<Vec<f64>> {
    let e = o.evaluate(p, usable)?;
    let mut r = e.residuals;
    r.extend(e.damping);
    if let Some(frf) = frf {
        r.extend(frf.residuals(o.prepared(), p)?);
    }
    Some(r)
}

/// How the residuals `r0` are correlated: the FRF part (the last
/// `frf.count()`) along frequency — re and im per line, so their lag-2
/// autocorrelation gives the AR(1) factor ([`ar1_inflation`]), and the
/// batch-means blocks follow their integrated correlation
/// ([`Correlation::of_frfs`]); without FRFs independent.
fn correlation(r0: &[f64], frf: Option<&FrfReference>) -> Correlation {
    let Some(frf) = frf.filter(|f| f.count() <= r0.len()) else {
        return Correlation::independent();
    };
    let leading = r0.len() - frf.count();
    Correlation::of_frfs(
        leading,
        &frf.layout(),
        frf_inflation(&r0[leading..]),
        &r0[leading..],
    )
}

/// The AR(1) factor of FRF residuals `frf_part` (re, im per line).
fn frf_inflation(frf_part: &[f64]) -> f64 {
    let lagged: f64 = frf_part
        .iter()
        .zip(frf_part.iter().skip(2))
        .map(|(a, b)| a * b)
        .sum();
    let energy: f64 = frf_part.iter().map(|v| v * v).sum();
    if energy > 0.0 {
        ar1_inflation(lagged / energy)
    } else {
        1.0
    }
}

/// `c` with each fixed parameter's linearized change cut at its bounds
/// (`fixed`: index and spread, in `c`'s order; `x`: all values).
fn cut_at_bounds(
    o: &ModalObjective,
    x: &[f64],
    fixed: &[(usize, f64)],
    mut c: Consider,
) -> Consider {
    // A linearized change is cut at the parameter's bounds (a column the
    // data barely see can ask for any value). Where it takes the parameter
    // into the outer 2.5 % of its range (`verdict::at_edge`, the test a
    // refitted value fails), it asks for a value the model file calls
    // barely possible.
    for (f, &(i, _)) in c.fixed.iter_mut().zip(fixed) {
        let p = &o.parameters()[i];
        if x[i] > 0.0 && p.lower > 0.0 {
            f.change = f.change.clamp((p.lower / x[i]).ln(), (p.upper / x[i]).ln());
            let u = p.scale.to_unit(x[i] * f.change.exp(), p.lower, p.upper);
            // Toward that edge: a file value already near a bound is not
            // what the data ask for.
            f.at_bound = match at_edge(u) {
                Some(Implausible::AtUpperBound) => f.change > 0.0,
                Some(Implausible::AtLowerBound) => f.change < 0.0,
                _ => false,
            };
        }
    }
    c
}

/// The parameters `identified` leaves fixed, with the spread each is
/// assumed to have (σ of ln p): `spread` for all when given, else uniform
/// over its bounds ([`super::consider::bounds_spread`]). Parameters with
/// equal bounds are left out: the model file declares them exact.
fn fixed_parameters(
    o: &ModalObjective,
    x: &[f64],
    identified: &[usize],
    spread: Option<f64>,
) -> Vec<(usize, f64)> {
    o.parameters()
        .iter()
        .enumerate()
        .filter(|(i, p)| !identified.contains(i) && p.upper > p.lower)
        .map(|(i, p)| {
            let s = spread.unwrap_or_else(|| {
                bounds_spread(
                    x[i],
                    p.lower,
                    p.upper,
                    p.scale == crate::parameter::Scale::Log,
                )
            });
            (i, s)
        })
        .collect()
}

/// Warnings for identified parameters that ended at a bound.
pub(super) fn bound_warnings(o: &ModalObjective, x: &[f64], identified: &[usize]) -> Vec<String> {
    let full = match o.bounds() {
        Ok(b) => b,
        Err(_) => return Vec::new(),
    };
    let u = full.to_unit(x);
    identified
        .iter()
        .filter(|&&i| !(1e-6..=1.0 - 1e-6).contains(&u[i]))
        .map(|&i| {
            let p = &o.parameters()[i];
            let side = if u[i] < 0.5 { "lower" } else { "upper" };
            format!(
                "{} ended at its {side} bound ({}): the bounds may be too tight or the model cannot represent the reference",
                p.name,
                sig(x[i], 3)
            )
        })
        .collect()
}

#[cfg(test)]
mod tests;
