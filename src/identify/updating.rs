//! Model updating end to end, whatever the strategy: the reference paired
//! with the model at its start values (correspondence, observability,
//! `exclude_modes`), the strategy itself, and its assessment at the result
//! (final pairing, identifiability and uncertainty, verdict). Every model
//! evaluation of the assessment is counted with the strategy's.

use super::correspondence::Correspondence;
use super::frf_objective::FrfReference;
use super::frf_refinement::{frf_refinement, FrfRefinement, FrfRefinementParams};
use super::guided::{guided, GuidedParams, GuidedResult, Screening};
use super::history::HistoryRow;
use super::identifiability::{analyze, Identifiability};
use super::objective::{Match, ModalObjective, SlotPairing};
use super::verdict::{FrfJudgement, ModeCounts, Status, Verdict};
use super::{black_box, IdentifyError};
use crate::optimize::jacobian;
use crate::optimize::slsqp::SlsqpParams;
use crate::optimize::{OptimizeResult, Optimizer};
use rayon::prelude::*;

/// The strategy and its settings.
#[derive(Clone, Copy)]
pub enum Strategy<'a> {
    /// PUB3: GSA subproblems, continuation refinement, damping fit.
    Guided {
        screening: Screening<'a>,
        settings: &'a GuidedParams,
        slsqp: &'a SlsqpParams,
    },
    /// One optimizer over all parameters on J.
    BlackBox { optimizer: &'a Optimizer },
}

/// Everything an update needs besides the objective.
#[derive(Clone, Copy)]
pub struct Plan<'a> {
    pub strategy: Strategy<'a>,
    pub budget: usize,
    pub seed: u64,
    /// Observability threshold on the sensor amplitude (0 keeps every mode).
    pub visibility: f64,
    /// Modes of the nominal model to leave out: (position, number).
    pub exclude: &'a [(u32, usize)],
    /// Largest a-priori relative standard error of an identifiable parameter.
    pub max_std_error: f64,
    /// The measured FRFs, when given: the last step refines the identified
    /// parameters on them ([`super::frf_refinement`]).
    pub frf: Option<(&'a FrfReference, &'a FrfRefinementParams)>,
}

/// A reference mode and its partner at the result.
#[derive(Clone, Debug)]
pub struct FinalPair {
    pub matched: Option<Match>,
    /// Increase of the pairing cost if this pair were forbidden.
    pub margin: f64,
}

/// The result of an update.
pub struct Update {
    pub start: Vec<f64>,
    pub x: Vec<f64>,
    pub history: Vec<HistoryRow>,
    /// All evaluations: the strategy's and the assessment's.
    pub evaluations: usize,
    pub assessment_evaluations: usize,
    /// J at `x` (the black-box criterion, for comparison across strategies).
    pub objective: f64,
    pub correspondence: Correspondence,
    /// Per slot and reference mode: the partner at the result.
    pub pairs: Vec<Vec<FinalPair>>,
    /// Parameters identified (indices) and their analysis, in that order.
    pub identified: Vec<usize>,
    pub identifiability: Identifiability,
    pub verdict: Verdict,
    pub guided: Option<GuidedResult>,
    pub optimizer: Option<OptimizeResult>,
    pub frf: Option<FrfRefinement>,
}

/// Update the model of `o` (exclusions are added to it) by `plan`.
pub fn update(
    o: &mut ModalObjective,
    plan: &Plan,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Update, IdentifyError> {
    let start = o.nominal();
    Correspondence::exclude_duplicates(o);
    let correspondence = Correspondence::new(o, &start, plan.visibility)?;
    progress(1);
    for &(position, number) in plan.exclude {
        let (slot, k) = correspondence
            .nominal_mode(position, number, &[])
            .map_err(|why| {
                IdentifyError::Invalid(format!("exclude_modes: p{position}.mode{number}: {why}"))
            })?;
        if let Some(r) = correspondence.slots[slot].nominal[k].reference {
            o.exclude(
                slot,
                r,
                format!("named in exclude_modes (p{position}.mode{number})"),
            );
        }
    }
    correspondence.exclude_unobservable(o);
    for p in 0..o.positions() {
        if o.usable()[p].iter().all(|u| !u) {
            return Err(IdentifyError::Invalid(format!(
                "no usable reference mode is left at position {} (all excluded: {}); lower `observability` or shorten `exclude_modes`",
                o.position(p).index,
                o.exclusion(p, 0).unwrap_or("excluded")
            )));
        }
    }
    let o = &*o;
    // The assessment's evaluations come out of the same budget: the final
    // pairing (3), J (1) and a Jacobian over at most every parameter (2n + 1).
    let reserve = 2 * o.parameters().len() + 5;
    let budget = plan
        .budget
        .checked_sub(reserve + 1)
        .filter(|&b| b > 0)
        .ok_or_else(|| {
            IdentifyError::Invalid(format!(
                "budget {} cannot pay the assessment of the result ({} evaluations) and a strategy; give more",
                plan.budget,
                reserve + 1
            ))
        })?;
    let frf_budget = match plan.frf {
        Some((_, s)) if s.enabled => (budget as f64 * s.share) as usize,
        _ => 0,
    };
    let budget = budget - frf_budget;
    let (mut x, history, mut evaluations, identified, status, guided_result, optimizer) =
        match plan.strategy {
            Strategy::Guided {
                screening,
                settings,
                slsqp,
            } => {
                let r = guided(
                    o,
                    &correspondence,
                    screening,
                    settings,
                    slsqp,
                    &start,
                    budget,
                    plan.seed,
                    progress,
                )?;
                let mut identified = r.stiffness.clone();
                identified.extend(&r.damping);
                identified.sort_unstable();
                (
                    r.x.clone(),
                    r.history.clone(),
                    r.evaluations,
                    identified,
                    r.status,
                    Some(r),
                    None,
                )
            }
            Strategy::BlackBox { optimizer } => {
                let r = black_box(o, optimizer, &start, budget, plan.seed, progress)?;
                let status = Status::of(&r.result.termination);
                let all = (0..o.parameters().len()).collect();
                (
                    r.result.x_best.clone(),
                    r.history,
                    r.result.evaluations,
                    all,
                    status,
                    None,
                    Some(r.result),
                )
            }
        };
    let mut frf_result = None;
    if let Some((reference, settings)) = plan.frf.filter(|_| frf_budget > 0) {
        // What the modes left undetermined is searched on the FRFs first.
        let (modal, cost) =
            identifiability_at(o, &x, &identified, plan.max_std_error, None, progress)?;
        evaluations += cost;
        let explore: Vec<usize> = identified
            .iter()
            .zip(&modal.parameters)
            .filter(|(_, p)| !p.identifiable)
            .map(|(&i, _)| i)
            .collect();
        let r = frf_refinement(
            o.prepared(),
            &o.bounds()?,
            reference,
            &identified,
            &explore,
            &x,
            &start,
            (frf_budget + budget).saturating_sub(evaluations),
            settings,
            plan.seed,
            progress,
        )?;
        evaluations += r.summary.evaluations;
        x = r.x.clone();
        frf_result = Some(r);
    }
    let (assessment, pairs, mut verdict_inputs, close_pairs) =
        assess(o, &start, &x, &identified, plan, progress)?;
    let mut warnings = bound_warnings(o, &x, &identified);
    warnings.extend(close_pairs);
    if let Some(run) = guided_result.as_ref().and_then(|g| g.refinement.first()) {
        verdict_inputs.2.outliers = run.outliers.len();
        warnings.extend(run.outliers.iter().map(|f| {
            format!(
                "reference mode {} at position {} ({:.2} Hz) down-weighted as an outlier: residual {:.1}σ RMS against a median of {:.1}σ",
                f.mode, f.position, f.frequency_hz, f.rms, f.median
            )
        }));
    }
    let verdict = Verdict::judge(
        status,
        verdict_inputs.0,
        verdict_inputs.1,
        verdict_inputs.2,
        identified.len(),
        assessment
            .0
            .parameters
            .iter()
            .filter(|p| p.identifiable)
            .count(),
        warnings,
    );
    // With FRFs they are the reference the verdict is about.
    let verdict = match &frf_result {
        Some(r) => verdict.with_frf(
            Status::of(&r.status),
            FrfJudgement::new(r.summary.start, r.summary.end),
        ),
        None => verdict,
    };
    let objective = o.cost(&x);
    progress(1);
    // Correspondence (1), final pairing (3), Jacobian (2n + 1), J (1).
    let assessment_evaluations = 1 + 3 + assessment.1 + 1;
    Ok(Update {
        objective,
        evaluations: evaluations + assessment_evaluations,
        assessment_evaluations,
        start,
        x,
        history,
        correspondence,
        pairs,
        identified,
        identifiability: assessment.0,
        verdict,
        guided: guided_result,
        optimizer,
        frf: frf_result,
    })
}

type Assessment = (
    (Identifiability, usize),
    Vec<Vec<FinalPair>>,
    (f64, f64, ModeCounts),
    Vec<String>,
);

/// The final pairing with margins, the weighted-residual RMS at the start
/// and the result, and the identifiability of `identified` at `x`.
fn assess(
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
        close.extend(unresolved_pairs(p, &mf, &rf, &matched[p]));
        pairs.push(slot);
    }
    let frf = plan.frf.map(|(r, _)| r);
    let identifiability = identifiability_at(o, x, identified, plan.max_std_error, frf, progress)?;
    Ok((
        identifiability,
        pairs,
        (rms(&at_start), rms(&at_x), counts),
        close,
    ))
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

/// The identifiability of `identified` at `x` from a forward-difference
/// Jacobian (central differences) of the weighted residuals (frequencies,
/// shapes and damping ratios of the usable modes, and the FRF residuals of
/// `frf` when given) with respect to ln p: one batch of
/// 2·`identified.len()` evaluations (+1 at `x`).
fn identifiability_at(
    o: &ModalObjective,
    x: &[f64],
    identified: &[usize],
    max_std_error: f64,
    frf: Option<&FrfReference>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Identifiability, usize), IdentifyError> {
    let usable = o.usable();
    let full = o.bounds()?;
    let residuals = |points: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        let v: Vec<_> = points
            .par_iter()
            .map(|u| {
                let mut p = x.to_vec();
                let phys = full.to_physical(u);
                for &i in identified {
                    p[i] = phys[i];
                }
                let e = o.evaluate(&p, &usable)?;
                let mut r = e.residuals;
                r.extend(e.damping);
                if let Some(frf) = frf {
                    r.extend(frf.residuals(o.prepared(), &p)?);
                }
                Some(r)
            })
            .collect();
        progress(points.len() as u64);
        v
    };
    let u = full.to_unit(x);
    let r0 = residuals(std::slice::from_ref(&u))
        .pop()
        .flatten()
        .ok_or_else(|| IdentifyError::Model("the model cannot be solved at the result".into()))?;
    // Perturb only the identified coordinates: a Jacobian over them alone.
    let batch = |points: &[Vec<f64>]| residuals(points);
    let sub_u: Vec<f64> = identified.iter().map(|&i| u[i]).collect();
    let embed = |points: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        let full_points: Vec<Vec<f64>> = points
            .iter()
            .map(|s| {
                let mut p = u.clone();
                for (j, &i) in identified.iter().enumerate() {
                    p[i] = s[j];
                }
                p
            })
            .collect();
        batch(&full_points)
    };
    let columns_u = jacobian::central(&embed, &sub_u, &r0, 1e-4);
    // ∂r/∂ln p = ∂r/∂u · du/d ln p.
    let columns: Vec<Vec<f64>> = columns_u
        .into_iter()
        .zip(identified)
        .map(|(col, &i)| {
            let (l, h) = (full.lower()[i], full.upper()[i]);
            let du_dlnp = full.scale()[i].du_dln_x(x[i], l, h);
            col.into_iter().map(|v| v * du_dlnp).collect()
        })
        .collect();
    let names: Vec<String> = identified
        .iter()
        .map(|&i| o.parameters()[i].name.clone())
        .collect();
    Ok((
        analyze(&columns, &r0, &names, max_std_error),
        2 * identified.len() + 1,
    ))
}

/// Warnings for identified parameters that ended at a bound.
fn bound_warnings(o: &ModalObjective, x: &[f64], identified: &[usize]) -> Vec<String> {
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
                "{} ended at its {side} bound ({:e}): the bounds may be too tight or the model cannot represent the reference",
                p.name, x[i]
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paired(model_mode: usize) -> Option<Match> {
        Some(Match {
            model_mode,
            frequency_hz: 0.0,
            damping_ratio: 0.05,
            mac: 1.0,
        })
    }

    /// Unpaired used reference modes are named with their numbers and
    /// frequencies; excluded modes (not in `idx`) and paired ones are not.
    #[test]
    fn unpaired_reference_modes_are_named() {
        let idx = [0, 2, 3];
        let rf = [17.1, 118.9, 155.5];
        let matched = [paired(0), None, None, paired(2)];
        let w = unpaired_text(0, &idx, &rf, &matched).unwrap();
        assert!(w.contains("reference mode without a model partner"), "{w}");
        assert!(
            w.contains("mode 3 (118.90 Hz)") && !w.contains("mode 2 "),
            "{w}"
        );
        assert!(!w.contains("17.10") && !w.contains("155.50"), "{w}");
        assert!(unpaired_text(0, &[0], &[17.1], &[paired(0)]).is_none());
    }

    #[test]
    fn a_model_pair_seen_as_one_reference_mode_is_named() {
        // Model: 40, 72.1, 72.9 (1.1 % apart), 100, 150 Hz; the reference
        // sees 40, 72.5 and 100 Hz, paired with model modes 1, 2 and 4.
        let mf = [40.0, 72.1, 72.9, 100.0, 150.0];
        let rf = [40.0, 72.5, 100.0];
        let w = unresolved_pairs(0, &mf, &rf, &[paired(0), paired(1), paired(3)]);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("model mode 3 (72.90 Hz)") && w[0].contains("reference mode 2"));
        // 150 Hz is outside the reference band, 100 Hz is paired: no more.
        let all = unresolved_pairs(0, &mf, &rf, &[paired(0), paired(1), paired(3)]);
        assert!(!all.iter().any(|m| m.contains("150")));
        // Well separated unpaired modes are not close pairs.
        let apart = unresolved_pairs(0, &[40.0, 60.0, 100.0], &rf, &[paired(0), None, paired(2)]);
        assert!(apart.is_empty(), "{apart:?}");
    }
}
