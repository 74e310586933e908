//! What an update does when its first result is not ok, before it judges
//! (issue 26: no stall left for the verdict to explain):
//!
//! - **Refit** ([`refit`]): the score test ([`super::consider`]) implicates
//!   parameters the screening held fixed; with `refit_implicated` they join
//!   the identified ones and the fit is refined over all of them — on the
//!   FRFs when given (their box searched first, as the FRF refinement does
//!   for what the modes left open), else by the modal continuation.
//! - **Escape** ([`escape`]): the fit ends above the noise and nothing is
//!   implicated; the FRF refinement runs again with a search over the box of
//!   *every* identified parameter (the first one searched only those the
//!   modes left undetermined), so a wrong basin the modes called determined
//!   can be left. Without FRFs the guided strategy's own restarts are the
//!   search. Whether a further start found a better fit is the evidence that
//!   tells a local minimum from model error ([`SearchEvidence`]).
//!
//! - **Window** ([`super::window_search`]): the FRF fit misses a resonance
//!   (its worst window of lines far above the noise); the parameters that
//!   mend that window when moved alone start refinements of all, before a
//!   refit or the escape spends the budget around it; one that gained
//!   materially and left such a window is followed by another where the
//!   budget allows (up to three in a row: mending one resonance of a sharp
//!   pair can misplace its partner, which the compensating parameters had
//!   held).
//!
//! All come out of the update's budget, after the strategy, in the order
//! [`next_step`] gives; each result is assessed and judged again.

use super::continuation::{continuation, ContinuationParams};
use super::frf_refinement::{frf_refinement, FrfRefinement};
use super::guided::GuidedResult;
use super::history::Recorder;
use super::local_misfit::LocalMisfit;
use super::updating::Plan;
use super::verdict::{SearchEvidence, Status};
use super::window_search::window_search;
use super::{IdentifyError, ModalObjective};
use serde::{Deserialize, Serialize};

/// A further start counts as a better minimum when its cost is below this
/// fraction of the first (robust cost ½‖r‖²): 10 % lower in RMS.
pub const ESCAPED: f64 = 0.81;

/// Fewest evaluations a follow-up is started with.
pub(super) const MINIMUM: usize = 64;

/// What one follow-up did (cost.json's `follow_ups`): so that an update's
/// evaluations add up and a reader sees what was tried before the verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FollowUpRecord {
    /// `refit` (implicated fixed parameters identified too), `escape` (a
    /// search over every identified parameter's box) or `window` (over the
    /// box of those acting on the worst FRF window).
    pub kind: FollowUpKind,
    pub evaluations: usize,
    /// Parameters it moved.
    pub parameters: usize,
    /// Fit RMS (σ units; the FRF fit when FRFs were given) before and at
    /// its own result.
    #[serde(deserialize_with = "super::verdict::nan_if_null")]
    pub rms_before: f64,
    #[serde(deserialize_with = "super::verdict::nan_if_null")]
    pub rms_after: f64,
    /// Its result replaced the update's (an escape: it fitted better; a
    /// refit: materially better).
    pub taken: bool,
}

/// The kind of a [`FollowUpRecord`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FollowUpKind {
    Refit,
    Escape,
    /// A search of the parameters acting on the worst FRF window
    /// ([`super::window_search`]).
    Window,
}

/// Where an update stands: its point, what it identified and how its last
/// optimizer ended.
#[derive(Clone)]
pub(super) struct Outcome {
    pub x: Vec<f64>,
    pub identified: Vec<usize>,
    pub status: Status,
    pub frf: Option<FrfRefinement>,
    pub evidence: SearchEvidence,
    /// The escape search ran.
    pub searched: bool,
    /// Fixed parameters the score test implicated and a refit identified.
    pub refitted: Vec<String>,
}

/// A follow-up's result: where the update stands after it, what it cost
/// and, for an escape, how its own best point ended.
pub(super) struct Step {
    pub outcome: Outcome,
    pub cost: usize,
    pub escape: Option<EscapeEnd>,
}

/// How an escape search ended.
#[derive(Clone, Copy)]
pub(super) struct EscapeEnd {
    /// FRF fit RMS (σ units) at its best point.
    pub rms: f64,
    /// It fitted better, so `Step::outcome` is its point; otherwise the
    /// outcome is the point it started from (searched, its evidence new).
    pub better: bool,
}

/// What the judgement of an update allows as its next follow-up.
pub(super) struct Next<'a> {
    /// The worst FRF window, far above the noise and not searched yet.
    pub window: Option<LocalMisfit>,
    /// Fixed parameters to refit.
    pub implicated: Option<&'a [usize]>,
    /// Above the noise and not searched over every box yet.
    pub escape: bool,
}

/// The next follow-up of `now` within `budget`, with its kind: a search of
/// the misfit window first when `next` asks for one ([`window_search`]: a
/// refit's parameters would compensate that resonance, and the escape
/// samples its few directions thinly), then a refit of the implicated
/// parameters, then the escape; the first that can run. `None`: the one
/// due could not run (no budget, no FRFs), or none is due.
pub(super) fn next_step(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    now: &Outcome,
    next: &Next,
    budget: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Option<(FollowUpKind, Step)>, IdentifyError> {
    if let Some(w) = next.window {
        if let Some(step) = window_search(o, plan, start, now, w, budget, progress)? {
            return Ok(Some((FollowUpKind::Window, step)));
        }
    }
    let step = if let Some(implicated) = next.implicated {
        refit(o, plan, start, now, implicated, budget, progress)?.map(|s| (FollowUpKind::Refit, s))
    } else if next.escape {
        escape(o, plan, start, now, budget, progress)?.map(|s| (FollowUpKind::Escape, s))
    } else {
        None
    };
    Ok(step)
}

/// Refit with the `implicated` fixed parameters identified too, from the
/// current result, within `budget`; `None` when the budget cannot pay it.
pub(super) fn refit(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    now: &Outcome,
    implicated: &[usize],
    budget: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Option<Step>, IdentifyError> {
    if budget < MINIMUM.max(8 * (now.identified.len() + implicated.len() + 1)) {
        return Ok(None);
    }
    let mut free = now.identified.clone();
    free.extend(implicated);
    free.sort_unstable();
    free.dedup();
    let mut refitted = now.refitted.clone();
    refitted.extend(implicated.iter().map(|&i| o.parameters()[i].name.clone()));
    // A budget below what the refinement needs skips the refit (the
    // verdict keeps the implicated parameters named).
    let (x, status, frf, cost) = match plan.frf.filter(|(_, s)| s.enabled) {
        Some((reference, settings)) => {
            let r = match frf_refinement(
                o.prepared(),
                &o.bounds()?,
                reference,
                &free,
                implicated,
                &now.x,
                start,
                budget,
                settings,
                plan.seed,
                progress,
            ) {
                Err(IdentifyError::Invalid(_)) => return Ok(None),
                r => r?,
            };
            let cost = r.summary.evaluations;
            (r.x.clone(), Status::of(&r.status), Some(r), cost)
        }
        None => {
            let recorder = Recorder::starting_at(0);
            let settings = ContinuationParams::default();
            let r = match continuation(
                o, &free, &now.x, start, budget, &settings, &recorder, progress,
            ) {
                Err(IdentifyError::Invalid(_)) => return Ok(None),
                r => r?,
            };
            (r.x, Status::of(&r.termination), None, r.evaluations)
        }
    };
    Ok(Some(Step {
        outcome: Outcome {
            x,
            identified: free,
            status,
            frf: frf.or_else(|| now.frf.clone()),
            evidence: now.evidence,
            searched: now.searched,
            refitted,
        },
        cost,
        escape: None,
    }))
}

/// With FRFs: search the box of every identified parameter and refine from
/// the best points and the current result; the better fit is kept and the
/// evidence records whether a further start won (nothing, when it found
/// nothing with less budget than the first FRF refinement used). `None`
/// without FRFs or budget.
pub(super) fn escape(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    now: &Outcome,
    budget: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Option<Step>, IdentifyError> {
    let Some((reference, settings)) = plan.frf.filter(|(_, s)| s.enabled) else {
        return Ok(None);
    };
    let Some((first, before)) = now
        .frf
        .as_ref()
        .map(|r| (r.summary.evaluations, r.summary.end))
    else {
        return Ok(None);
    };
    if budget < MINIMUM.max(8 * (now.identified.len() + 1)) {
        return Ok(None);
    }
    // A search that finds nothing better is the evidence for model error
    // only when it was at least as thorough as the refinement it
    // second-guesses; a shorter one may still find a better basin (taken),
    // but its failure to is no evidence (the causes stay not told apart).
    let thorough = budget >= first;
    let r = match frf_refinement(
        o.prepared(),
        &o.bounds()?,
        reference,
        &now.identified,
        &now.identified,
        &now.x,
        start,
        budget,
        settings,
        plan.seed.wrapping_add(1),
        progress,
    ) {
        Err(IdentifyError::Invalid(_)) => return Ok(None),
        r => r?,
    };
    let cost = r.summary.evaluations;
    let escaped = r.summary.end.robust_cost < ESCAPED * before.robust_cost;
    let evidence = SearchEvidence {
        escaped: (escaped || thorough).then_some(escaped),
        short: (!escaped && !thorough).then_some((cost, first)),
    };
    Ok(Some(searched_step(now, r, evidence, true, cost)))
}

/// The step of a search that ended at `r` from `now`: its point when it
/// fits better (robust FRF cost), else `now`'s, with the search's
/// `evidence` and `searched` (it covered every identified parameter's box).
pub(super) fn searched_step(
    now: &Outcome,
    r: FrfRefinement,
    evidence: SearchEvidence,
    searched: bool,
    cost: usize,
) -> Step {
    let before = now.frf.as_ref().map(|f| f.summary.end.robust_cost);
    let better = before.is_some_and(|b| r.summary.end.robust_cost < b);
    let rms = r.summary.end.rms;
    let mut outcome = now.clone();
    if better {
        outcome.x = r.x.clone();
        outcome.status = Status::of(&r.status);
        outcome.frf = Some(r);
    }
    outcome.evidence = evidence;
    outcome.searched = searched;
    Step {
        outcome,
        cost,
        escape: Some(EscapeEnd { rms, better }),
    }
}

/// The guided strategy's own restarts as evidence: several refinement runs
/// ran (the modal fit was above the noise) and a later start won. When the
/// FRFs were fitted after them (`on_frfs`) the verdict judges the FRF fit,
/// and restarts on the modes that found nothing better say nothing about
/// the FRF misfit's minima: only a win counts then (the landscape has other
/// minima), a miss is no evidence — the FRF escape search is.
pub(super) fn escape_evidence(guided: Option<&GuidedResult>, on_frfs: bool) -> SearchEvidence {
    let ends: Vec<f64> = guided.map_or(vec![], |g| g.refinement.iter().map(|r| r.end).collect());
    restart_evidence(&ends, on_frfs)
}

/// [`escape_evidence`] from the refinement runs' final costs.
fn restart_evidence(ends: &[f64], on_frfs: bool) -> SearchEvidence {
    if ends.len() < 2 {
        return SearchEvidence::default();
    }
    let best = ends.iter().copied().fold(f64::INFINITY, f64::min);
    let escaped = best < ESCAPED * ends[0];
    SearchEvidence {
        escaped: (escaped || !on_frfs).then_some(escaped),
        short: None,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::dynamics::PreparedModel;
    use crate::identify::black_box::tests::{model, objective, truth};
    use crate::identify::frf_objective::{FrfNoise, FrfReference};
    use crate::identify::frf_refinement::FrfRefinementParams;

    /// The three-mass chain's FRFs at 1 % noise for the values `t`, as a
    /// reference for a model of it.
    pub(crate) fn chain_reference(t: &[f64]) -> FrfReference {
        let prepared = PreparedModel::new(&model()).unwrap();
        let set = crate::identify::frf_refinement::tests::measured(&prepared, t, 0.01, 3);
        FrfReference::new(&prepared, &[set], None, (10.0, 400.0), FrfNoise::default()).unwrap()
    }

    /// The FRF refinement of `free` from `x0` with `settings`: a planted
    /// basin's stuck point.
    pub(crate) fn stuck_at(
        r: &FrfReference,
        free: &[usize],
        x0: &[f64],
        settings: &FrfRefinementParams,
    ) -> FrfRefinement {
        let o = objective();
        let bounds = o.bounds().unwrap();
        frf_refinement(
            o.prepared(),
            &bounds,
            r,
            free,
            &[],
            x0,
            &o.nominal(),
            3000,
            settings,
            1,
            &|_| {},
        )
        .unwrap()
    }

    /// A plan that refines on the FRFs `r` (a budget of 10,000, seed 1).
    pub(in crate::identify) fn frf_plan<'a>(
        r: &'a FrfReference,
        settings: &'a FrfRefinementParams,
        optimizer: &'a crate::optimize::Optimizer,
    ) -> Plan<'a> {
        Plan {
            strategy: crate::identify::Strategy::BlackBox { optimizer },
            budget: 10_000,
            seed: 1,
            observability: crate::identify::Observability::all(),
            exclude: &[],
            max_std_error: 0.1,
            fixed_spread: None,
            refit_implicated: true,
            frf: Some((r, settings)),
        }
    }

    /// An update stalled at `stuck`, every parameter identified.
    pub(in crate::identify) fn stalled_at(stuck: FrfRefinement) -> Outcome {
        Outcome {
            x: stuck.x.clone(),
            identified: (0..stuck.x.len()).collect(),
            status: Status::Stalled,
            frf: Some(stuck),
            evidence: SearchEvidence::default(),
            searched: false,
            refitted: Vec::new(),
        }
    }

    /// A planted local minimum: the three-mass chain's stiffnesses
    /// permuted (k1 ← k12, k12 ← k23, k23 ← k3, k3 ← k1). Levenberg–Marquardt
    /// on the FRFs from there stalls far above the noise (the first FRF
    /// refinement searched only what the modes left open: nothing here); the
    /// escape searches every identified parameter's box, reaches the noise
    /// and records that a further start won.
    #[test]
    fn a_planted_local_minimum_is_escaped() {
        let o = objective();
        let t = truth();
        let r = chain_reference(&t);
        let mut x0 = t.clone();
        for (k, from) in [1, 2, 3, 0].into_iter().enumerate() {
            x0[k] = t[from];
        }
        let free: Vec<usize> = (0..8).collect();
        let settings = FrfRefinementParams::default();
        // The stuck point is planted with a forward-difference Jacobian at
        // every step: from the permutation the secant iteration happens to
        // walk to the truth by itself (0.99σ in 254 evaluations), which says
        // nothing about the escape.
        let planting = FrfRefinementParams {
            secant: false,
            ..settings.clone()
        };
        let stuck = stuck_at(&r, &free, &x0, &planting);
        assert!(stuck.summary.end.rms > 10.0, "{:?}", stuck.summary);
        let optimizer = crate::optimize::Optimizer::from_settings("slsqp", None).unwrap();
        let plan = frf_plan(&r, &settings, &optimizer);
        let now = stalled_at(stuck);
        let Step {
            outcome: next,
            cost,
            escape: end,
        } = escape(&o, &plan, &o.nominal(), &now, 3000, &|_| {})
            .unwrap()
            .unwrap();
        let end = end.unwrap();
        assert!(end.better);
        assert_eq!(end.rms, next.frf.as_ref().unwrap().summary.end.rms);
        assert!(cost <= 3000);
        assert!(next.searched && next.evidence.escaped == Some(true));
        let end = next.frf.as_ref().unwrap().summary.end;
        assert!(end.rms < 1.1, "{end:?}");
        for (k, (x, t)) in next.x.iter().zip(&t).take(4).enumerate() {
            assert!((x / t - 1.0).abs() < 2e-3, "k{k}: {x}");
        }
        // Already at the truth: nothing better, and the evidence says so.
        let held = escape(&o, &plan, &o.nominal(), &next, 3000, &|_| {})
            .unwrap()
            .unwrap();
        assert!(!held.escape.unwrap().better);
        assert_eq!(held.outcome.x, next.x);
        let held = held.outcome;
        assert_eq!(held.evidence.escaped, Some(false));
        // With less budget than the first refinement used, finding nothing
        // better is no evidence either way.
        let first = next.frf.as_ref().unwrap().summary.evaluations;
        assert!(first > 100, "{first}");
        let short = escape(&o, &plan, &o.nominal(), &next, first - 1, &|_| {})
            .unwrap()
            .unwrap()
            .outcome;
        assert_eq!(short.evidence.escaped, None);
        assert_eq!(short.evidence.short.map(|s| s.1), Some(first));
        assert_eq!(held.evidence.short, None);
    }

    #[test]
    fn modal_restarts_that_find_nothing_better_are_no_evidence_about_the_frfs() {
        let (won, lost) = ([4.0, 2.0, 5.0], [4.0, 3.9, 5.0]);
        assert_eq!(restart_evidence(&won, false).escaped, Some(true));
        assert_eq!(restart_evidence(&lost, false).escaped, Some(false));
        // The FRFs were fitted after the restarts: a win still shows other
        // minima; a miss says nothing about the FRF misfit.
        assert_eq!(restart_evidence(&won, true).escaped, Some(true));
        assert_eq!(restart_evidence(&lost, true).escaped, None);
        assert_eq!(restart_evidence(&[4.0], false).escaped, None);
    }
}
