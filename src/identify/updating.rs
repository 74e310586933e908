//! Model updating end to end, whatever the strategy: the reference paired
//! with the model at its start values (correspondence, observability,
//! `exclude_modes`), the strategy itself, and its assessment at the result
//! (final pairing, identifiability and uncertainty, verdict). Every model
//! evaluation of the assessment is counted with the strategy's.

use super::assessment::identifiability_at;
use super::consider::Consider;
use super::correspondence::{Correspondence, Observability};
use super::follow_up::{escape_evidence, FollowUpRecord, Outcome};
use super::frf_objective::FrfReference;
use super::frf_refinement::{frf_refinement, FrfRefinement, FrfRefinementParams};
use super::guided::{guided, GuidedParams, GuidedResult, Screening};
use super::history::HistoryRow;
use super::identifiability::Identifiability;
use super::objective::{Match, ModalObjective};
use super::verdict::{Status, Verdict};
use super::{black_box, IdentifyError};
use crate::optimize::slsqp::SlsqpParams;
use crate::optimize::{OptimizeResult, Optimizer};
use judging::{FollowUps, Standing};

mod judging;

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
    /// Thresholds on the sensor amplitude below which a mode is left out,
    /// or compared by frequency alone.
    pub observability: Observability,
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
    /// The first FRF refinement's evaluations (its identifiability analysis
    /// included; 0 when it did not run): `frf` may be a follow-up's.
    pub frf_evaluations: usize,
    /// The follow-ups that ran after the strategy ([`super::follow_up`]).
    pub follow_ups: Vec<FollowUpRecord>,
}

/// Update the model of `o` (exclusions are added to it) by `plan`.
pub fn update(
    o: &mut ModalObjective,
    plan: &Plan,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Update, IdentifyError> {
    let start = o.nominal();
    let correspondence = pair_at_start(o, &start, plan, progress)?;
    let o = &*o;
    let budgets = Budgets::split(o, plan)?;
    let searched = run_strategy(o, &correspondence, plan, &start, budgets.strategy, progress)?;
    let mut evaluations = searched.evaluations;
    let mut x = searched.x.clone();
    let mut frf_result = None;
    let mut frf_evaluations = 0;
    if let Some((r, cost)) = refine_on_frfs(o, plan, &start, &searched, &budgets, progress)? {
        evaluations += cost;
        frf_evaluations = cost;
        x = r.x.clone();
        frf_result = Some(r);
    }
    let Searched {
        history,
        identified,
        status,
        guided: guided_result,
        optimizer,
        ..
    } = searched;
    let outcome = Outcome {
        x,
        identified,
        status,
        evidence: escape_evidence(guided_result.as_ref(), frf_result.is_some()),
        frf: frf_result,
        searched: false,
        refitted: Vec::new(),
    };
    let follow = FollowUps {
        o,
        plan,
        start: &start,
        guided: guided_result.as_ref(),
        reserve: budgets.reserve,
        progress,
    };
    let judged = follow.judge(&outcome)?;
    let standing = follow.run(Standing {
        assessment_evaluations: judged.evaluations,
        outcome,
        judged,
        evaluations,
        material: Vec::new(),
        refutation: None,
        follow_ups: Vec::new(),
    })?;
    let Standing {
        outcome,
        judged,
        evaluations,
        mut assessment_evaluations,
        material,
        follow_ups,
        ..
    } = standing;
    let values = judging::refit_values(o, plan, &start, &outcome, &judged, &material);
    let verdict = judged
        .verdict
        .clone()
        .with_refitted(values)
        .classified(outcome.evidence)
        .explained();
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
        frf_evaluations,
        follow_ups,
    })
}

/// The start of an update: the reference paired with the model at `start`
/// (duplicates, the modes `exclude_modes` names and the unobservable ones
/// excluded from `o`); an error when a position is left without a usable
/// reference mode.
fn pair_at_start(
    o: &mut ModalObjective,
    start: &[f64],
    plan: &Plan,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Correspondence, IdentifyError> {
    Correspondence::exclude_duplicates(o);
    let correspondence = Correspondence::new(o, start, plan.observability)?;
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
    Ok(correspondence)
}

/// The evaluations the assessment of a result over `n` parameters may
/// need within `budget`, kept from it: the final pairing (3), J (1), a
/// Jacobian over at most every parameter (2n + 1), and, where the budget
/// affords it ([`checks_intervals`]), the check of at most n intervals
/// against the cost (2n + 1, [`super::curvature`]).
pub fn assessment_reserve(n: usize, budget: usize) -> usize {
    (2 * n + 5)
        + if checks_intervals(n, budget) {
            2 * n + 1
        } else {
            0
        }
}

/// Whether an update over `n` parameters with `budget` evaluations checks
/// its intervals against the cost: when that costs at most 5 % of the
/// budget, so that a small budget goes to the search.
pub fn checks_intervals(n: usize, budget: usize) -> bool {
    20 * (2 * n + 1) <= budget
}

/// How an update's budget is shared out.
struct Budgets {
    /// Kept for the assessment of the result.
    reserve: usize,
    /// The strategy's.
    strategy: usize,
    /// The FRF refinement's (0: it does not run).
    frf: usize,
}

impl Budgets {
    /// Split `plan.budget`: the assessment's reserve first, then the FRF
    /// refinement's share of the rest, the strategy the remainder; an error
    /// when the budget cannot pay the assessment and a strategy.
    fn split(o: &ModalObjective, plan: &Plan) -> Result<Budgets, IdentifyError> {
        // The assessment's evaluations come out of the same budget.
        let reserve = assessment_reserve(o.parameters().len(), plan.budget);
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
        Ok(Budgets {
            reserve,
            strategy: budget - frf_budget,
            frf: frf_budget,
        })
    }
}

/// What the strategy found.
struct Searched {
    x: Vec<f64>,
    history: Vec<HistoryRow>,
    evaluations: usize,
    /// The parameters it identified (indices, ascending).
    identified: Vec<usize>,
    status: Status,
    guided: Option<GuidedResult>,
    optimizer: Option<OptimizeResult>,
}

/// The search: `plan`'s strategy from `start` with at most `budget`
/// evaluations.
fn run_strategy(
    o: &ModalObjective,
    correspondence: &Correspondence,
    plan: &Plan,
    start: &[f64],
    budget: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Searched, IdentifyError> {
    Ok(match plan.strategy {
        Strategy::Guided {
            screening,
            settings,
            slsqp,
        } => {
            let r = guided(
                o,
                correspondence,
                screening,
                settings,
                slsqp,
                start,
                budget,
                plan.seed,
                progress,
            )?;
            let mut identified = r.stiffness.clone();
            identified.extend(&r.damping);
            identified.sort_unstable();
            Searched {
                x: r.x.clone(),
                history: r.history.clone(),
                evaluations: r.evaluations,
                identified,
                status: r.status,
                guided: Some(r),
                optimizer: None,
            }
        }
        Strategy::BlackBox { optimizer } => {
            let r = black_box(o, optimizer, start, budget, plan.seed, progress)?;
            let status = Status::of(&r.result.termination);
            let all = (0..o.parameters().len()).collect();
            Searched {
                x: r.result.x_best.clone(),
                history: r.history,
                evaluations: r.result.evaluations,
                identified: all,
                status,
                guided: None,
                optimizer: Some(r.result),
            }
        }
    })
}

/// The refinement on the measured FRFs when `plan` has them and a share of
/// the budget: the result and the evaluations it cost (its identifiability
/// analysis included); `None` when it does not run.
fn refine_on_frfs(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    searched: &Searched,
    budgets: &Budgets,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Option<(FrfRefinement, usize)>, IdentifyError> {
    let Some((reference, settings)) = plan.frf.filter(|_| budgets.frf > 0) else {
        return Ok(None);
    };
    let (x, identified) = (&searched.x, &searched.identified);
    // What the modes left undetermined is searched on the FRFs first.
    let ((modal, _, cost), _) =
        identifiability_at(o, x, identified, &[], plan.max_std_error, None, progress)?;
    let evaluations = searched.evaluations + cost;
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
        identified,
        &explore,
        x,
        start,
        (budgets.frf + budgets.strategy).saturating_sub(evaluations),
        settings,
        plan.seed,
        progress,
    )?;
    let used = cost + r.summary.evaluations;
    Ok(Some((r, used)))
}
