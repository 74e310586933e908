//! Model updating end to end, whatever the strategy: the reference paired
//! with the model at its start values (correspondence, observability,
//! `exclude_modes`), the strategy itself, and its assessment at the result
//! (final pairing, identifiability and uncertainty, verdict). Every model
//! evaluation of the assessment is counted with the strategy's.

use super::assessment::{assess, bound_warnings, identifiability_at};
use super::consider::Consider;
use super::correspondence::Correspondence;
use super::follow_up::{escape, escape_evidence, refit, Outcome, ESCAPED};
use super::frf_objective::FrfReference;
use super::frf_refinement::{frf_refinement, FrfRefinement, FrfRefinementParams};
use super::guided::{guided, GuidedParams, GuidedResult, Screening};
use super::history::HistoryRow;
use super::identifiability::Identifiability;
use super::objective::{Match, ModalObjective};
use super::verdict::{Fit, FrfJudgement, Status, Verdict};
use super::{black_box, IdentifyError};
use crate::optimize::slsqp::SlsqpParams;
use crate::optimize::{OptimizeResult, Optimizer};

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
    /// The spread (σ of ln p) assumed for every parameter left fixed; `None`:
    /// uniform over its bounds ([`super::consider`]).
    pub fixed_spread: Option<f64>,
    /// Identify the fixed parameters the score test implicates too, and
    /// refit ([`super::follow_up`]).
    pub refit_implicated: bool,
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
    /// The fixed parameters' consider analysis and score tests (none when
    /// every parameter was identified).
    pub consider: Option<Consider>,
    pub verdict: Verdict,
    pub guided: Option<GuidedResult>,
    pub optimizer: Option<OptimizeResult>,
    pub frf: Option<FrfRefinement>,
    /// Fixed parameters the score test implicated and a refit identified.
    pub refitted: Vec<String>,
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
        let (modal, _, cost) =
            identifiability_at(o, &x, &identified, &[], plan.max_std_error, None, progress)?;
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
    let mut outcome = Outcome {
        x,
        identified,
        status,
        frf: frf_result,
        evidence: escape_evidence(guided_result.as_ref()),
        searched: false,
        refitted: Vec::new(),
    };
    let mut judged = judge(o, &start, &outcome, guided_result.as_ref(), plan, progress)?;
    let mut assessment_evaluations = judged.evaluations;
    // Refitted parameters whose refit fitted materially better (cost below
    // ESCAPED of before): only these make the screening the verdict's cause
    // (a refit that gains little says the misfit lies elsewhere).
    let mut material: Vec<String> = Vec::new();
    // A refit that did not fit better refutes the implication: the verdict
    // is judged without it, and the escape search may run instead.
    let mut refuted = false;
    // The follow-ups ([`super::follow_up`]), each judged again; a refit that
    // does not fit better is not taken.
    for _ in 0..2 {
        let left = plan
            .budget
            .saturating_sub(evaluations + assessment_evaluations + reserve);
        let mut implicated = judged.implicated(o);
        implicated.truncate(REFIT_AT_ONCE);
        let refitting = !implicated.is_empty() && plan.refit_implicated && !refuted;
        let step = if refitting {
            refit(o, plan, &start, &outcome, &implicated, left, progress)?
        } else if judged.verdict.fit == Fit::AboveNoise && !outcome.searched {
            escape(o, plan, &start, &outcome, left, progress)?
        } else {
            None
        };
        let Some((next, cost)) = step else { break };
        evaluations += cost;
        let mut next_judged = judge(o, &start, &next, guided_result.as_ref(), plan, progress)?;
        assessment_evaluations += next_judged.evaluations;
        // NaN (unsolvable) is never better.
        let better = fit_rms(&next_judged.verdict)
            .partial_cmp(&fit_rms(&judged.verdict))
            .is_some_and(|o| o.is_lt());
        if refitting && !better {
            let (now, then) = (fit_rms(&judged.verdict), fit_rms(&next_judged.verdict));
            let names = judged.verdict.implicated.join(", ");
            // The implication is refuted: within the noise it was
            // statistical, not practical (thousands of FRF lines make a tiny
            // structure significant); above it, the misfit is not theirs and
            // the escape search may tell a local minimum from model error.
            let within = judged.verdict.fit == Fit::WithinNoise;
            judged.verdict = judged.untested.clone();
            judged.verdict.warnings.push(format!(
                "the score test implicated {names}, but identifying them too did not fit better ({then:.2}σ against {now:.2}σ): {}",
                if within {
                    "the fit is within the noise, not counted against the verdict"
                } else {
                    "not taken, and the misfit is judged as not theirs"
                }
            ));
            refuted = true;
            if within {
                break;
            }
            continue;
        }
        if refitting {
            let (now, then) = (fit_rms(&judged.verdict), fit_rms(&next_judged.verdict));
            if (then / now).powi(2) < ESCAPED {
                material.clone_from(&next.refitted);
            } else {
                next_judged.verdict.warnings.push(format!(
                    "refitting with the implicated parameters identified too fitted only slightly better ({then:.2}σ against {now:.2}σ): weak evidence that the screening is the cause"
                ));
            }
        }
        outcome = next;
        judged = next_judged;
    }
    let mut verdict = judged.verdict.clone();
    verdict.refitted = material;
    let verdict = verdict.classified(outcome.evidence).explained();
    let objective = o.cost(&outcome.x);
    progress(1);
    assessment_evaluations += 1 + 1;
    Ok(Update {
        objective,
        evaluations: evaluations + assessment_evaluations,
        assessment_evaluations,
        start,
        x: outcome.x,
        history,
        correspondence,
        pairs: judged.pairs,
        identified: outcome.identified,
        identifiability: judged.identifiability,
        consider: judged.consider,
        verdict,
        guided: guided_result,
        optimizer,
        frf: outcome.frf,
        refitted: outcome.refitted,
    })
}

/// Most implicated parameters one refit adds (largest statistics first).
const REFIT_AT_ONCE: usize = 3;

/// The residual RMS (σ units) a verdict is about: the FRFs' when given.
fn fit_rms(v: &Verdict) -> f64 {
    v.frf.map_or(v.end_rms, |f| f.end.rms)
}

/// The assessment and verdict of an [`Outcome`].
struct Judged {
    verdict: Verdict,
    /// The verdict before the score test's implicated parameters counted.
    untested: Verdict,
    identifiability: Identifiability,
    consider: Option<Consider>,
    pairs: Vec<Vec<FinalPair>>,
    evaluations: usize,
}

impl Judged {
    /// Indices of the implicated fixed parameters, largest statistic first.
    fn implicated(&self, o: &ModalObjective) -> Vec<usize> {
        let Some(c) = &self.consider else {
            return Vec::new();
        };
        c.implicated()
            .iter()
            .filter_map(|f| o.parameters().iter().position(|p| p.name == f.parameter))
            .collect()
    }
}

/// Assess `outcome` and judge it: against the reference modes, then (with
/// FRFs) against the FRFs, then the score test's implicated parameters.
fn judge(
    o: &ModalObjective,
    start: &[f64],
    outcome: &Outcome,
    guided: Option<&GuidedResult>,
    plan: &Plan,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Judged, IdentifyError> {
    let ((identifiability, consider, cost), pairs, mut counts, close_pairs, damping) =
        assess(o, start, &outcome.x, &outcome.identified, plan, progress)?;
    let mut warnings = bound_warnings(o, &outcome.x, &outcome.identified);
    warnings.extend(close_pairs);
    if let Some(run) = guided.and_then(|g| g.refinement.first()) {
        counts.2.outliers = run.outliers.len();
        warnings.extend(run.outliers.iter().map(|f| {
            format!(
                "reference mode {} at position {} ({:.2} Hz) down-weighted as an outlier: residual {:.1}σ RMS against a median of {:.1}σ",
                f.mode, f.position, f.frequency_hz, f.rms, f.median
            )
        }));
    }
    if !outcome.refitted.is_empty() {
        warnings.push(format!(
            "the score test implicated {} (held fixed by the screening); identified too and refitted",
            outcome.refitted.join(", ")
        ));
    }
    let identifiable = identifiability
        .parameters
        .iter()
        .filter(|p| p.identifiable)
        .count();
    let verdict = Verdict::judge(
        outcome.status,
        counts.0,
        counts.1,
        counts.2,
        outcome.identified.len(),
        identifiable,
        warnings,
    );
    // With FRFs they are the reference the verdict is about (damping
    // included); from modes alone the identified damping is judged apart.
    let verdict = match (&outcome.frf, damping) {
        (Some(r), _) => verdict.with_frf(
            Status::of(&r.status),
            FrfJudgement::new(r.summary.start, r.summary.end),
        ),
        (None, Some(d)) => verdict.with_damping(d),
        (None, None) => verdict,
    };
    let implicated: Vec<(String, f64, f64)> = consider.as_ref().map_or(Vec::new(), |c| {
        c.implicated()
            .iter()
            .map(|f| (f.parameter.clone(), f.change, f.statistic))
            .collect()
    });
    Ok(Judged {
        untested: verdict.clone(),
        verdict: verdict.with_implicated(&implicated),
        identifiability,
        consider,
        pairs,
        // Final pairing (3) and the Jacobian batch.
        evaluations: 3 + cost,
    })
}
