//! The judging of an update's result and its follow-ups: each outcome
//! assessed ([`super::super::assessment`]) and judged into a [`Verdict`]; a
//! search of the FRF fit's misfit window, a refit of the parameters the score
//! test implicates, or the escape search ([`super::super::follow_up`]),
//! judged again and taken when it fits better (a refit: materially better).

use super::super::assessment::{assess, bound_warnings};
use super::super::consider::Consider;
use super::super::follow_up::{
    next_step, FollowUpKind, FollowUpRecord, Next, Outcome, Step, ESCAPED,
};
use super::super::guided::GuidedResult;
use super::super::identifiability::Identifiability;
use super::super::objective::ModalObjective;
use super::super::verdict::{
    Fit, FrfJudgement, Implication, RefitValue, Status, Verdict, LOCAL_NOISE_RMS,
};
use super::super::IdentifyError;
use super::{FinalPair, Plan};
use crate::numbers::sig;

/// Where the judging of an update stands.
pub(super) struct Standing {
    pub(super) outcome: Outcome,
    pub(super) judged: Judged,
    /// The strategy's and the follow-ups' evaluations.
    pub(super) evaluations: usize,
    /// The assessments' evaluations.
    pub(super) assessment_evaluations: usize,
    /// Refitted parameters whose refit fitted materially better (cost below
    /// ESCAPED of before): only these make the screening the verdict's cause
    /// (a refit that gains little says the misfit lies elsewhere).
    pub(super) material: Vec<String>,
    /// A refit that did not fit better refutes the implication: the verdict
    /// is judged without it (on every later judgement too: an escape's
    /// result is judged afresh), and the escape search may run instead.
    pub(super) refutation: Option<Refutation>,
    /// The follow-ups that ran, in order.
    pub(super) follow_ups: Vec<FollowUpRecord>,
}

/// What the judging and the follow-ups of an update work with.
pub(super) struct FollowUps<'a> {
    pub(super) o: &'a ModalObjective,
    pub(super) plan: &'a Plan<'a>,
    pub(super) start: &'a [f64],
    pub(super) guided: Option<&'a GuidedResult>,
    /// Evaluations kept for the final assessment.
    pub(super) reserve: usize,
    pub(super) progress: &'a (dyn Fn(u64) + Sync),
}

impl FollowUps<'_> {
    /// [`judge`] `outcome`.
    pub(super) fn judge(&self, outcome: &Outcome) -> Result<Judged, IdentifyError> {
        judge(
            self.o,
            self.start,
            outcome,
            self.guided,
            self.plan,
            self.progress,
        )
    }

    /// The follow-ups ([`super::follow_up`]) from the first judgement, each
    /// judged again; a refit that does not fit materially better is not
    /// taken.
    pub(super) fn run(&self, mut s: Standing) -> Result<Standing, IdentifyError> {
        let (o, plan, start, progress) = (self.o, self.plan, self.start, self.progress);
        // At most three follow-ups: the window search, then a refit or the
        // escape twice (as before the window search existed); a window
        // search that gained materially and left a window far above the
        // noise is followed by another ([`WINDOW_SEARCHES`]), on top.
        for round in 0.. {
            if round >= 3 + window_searches(&s.follow_ups).saturating_sub(1) {
                break;
            }
            // The reserve pays the judgement of what a follow-up returns;
            // one more for the result's J at the end (the strategy's share
            // keeps the same one back: `Budgets::split`). Without it a
            // follow-up that used all it was given ended one over the
            // budget (the mill's impact family: 16,001 of 16,000).
            let left = plan
                .budget
                .saturating_sub(s.evaluations + s.assessment_evaluations + self.reserve + 1);
            let mut implicated = s.judged.implicated(o);
            implicated.truncate(REFIT_AT_ONCE);
            let mut refitting =
                !implicated.is_empty() && plan.refit_implicated && s.refutation.is_none();
            let frf_rms = s.judged.verdict.frf.map(|f| f.end.rms);
            if refitting && !refit_can_gain(s.judged.verdict.fit, frf_rms) {
                s.refutation = Some(refute_at_floor(&mut s.judged));
                refitting = false;
            }
            let next = Next {
                window: s
                    .judged
                    .verdict
                    .misplaced_window()
                    .filter(|_| window_due(&s.follow_ups, left)),
                implicated: refitting.then_some(implicated.as_slice()),
                escape: s.judged.verdict.fit == Fit::AboveNoise && !s.outcome.searched,
            };
            let Some((
                kind,
                Step {
                    outcome: next,
                    cost,
                    escape: end,
                },
            )) = next_step(o, plan, start, &s.outcome, &next, left, progress)?
            else {
                break;
            };
            let refitting = kind == FollowUpKind::Refit;
            s.evaluations += cost;
            let before = fit_rms(&s.judged.verdict);
            let record = |rms_after: f64, taken: bool| FollowUpRecord {
                kind,
                evaluations: cost,
                parameters: next.identified.len(),
                rms_before: before,
                rms_after,
                taken,
            };
            // An escape that found nothing better leaves the point as it
            // was judged: only its evidence is new (the verdict is
            // classified with it at the end), so it is not judged again.
            if let Some(e) = end.filter(|e| !e.better) {
                s.follow_ups.push(record(e.rms, false));
                s.outcome = next;
                continue;
            }
            let mut next_judged = self.judge(&next)?;
            s.assessment_evaluations += next_judged.evaluations;
            let after = fit_rms(&next_judged.verdict);
            let gain = Gain::of(before, after);
            s.follow_ups
                .push(record(after, !refitting || gain == Gain::Material));
            if let Some(r) = &s.refutation {
                next_judged.keep_refutation(r);
            }
            if refitting && gain != Gain::Material {
                let (refutation, within) =
                    refute(&mut s.judged, &next_judged, gain == Gain::Slight);
                s.refutation = Some(refutation);
                if within {
                    break;
                }
                continue;
            }
            if refitting {
                s.material.clone_from(&next.refitted);
                let moved = largest_moves(o, &s.outcome, &next.x);
                gained(&mut next_judged, &next.refitted, &s.judged, &moved);
            }
            s.outcome = next;
            s.judged = next_judged;
        }
        Ok(s)
    }
}

/// Record on the judgement of a refit of `names` that fitted materially
/// better than `before` how much, and the identified parameters it `moved`
/// most (in both its verdicts: a later refuted refit goes back to the
/// untested one).
fn gained(judged: &mut Judged, names: &[String], before: &Judged, moved: &str) {
    let text = format!(
        "identifying {} too fitted materially better ({:.2}σ against {:.2}σ): taken; the already identified parameters it moved most: {moved}",
        names.join(", "),
        fit_rms(&judged.verdict),
        fit_rms(&before.verdict)
    );
    judged.verdict.warnings.push(text.clone());
    judged.untested.warnings.push(text);
}

/// The [`MOVES_NAMED`] parameters identified at `before` that moved most (in
/// ln p) to `x`, with their ratio: "nut.k_rz ×1.31, …".
fn largest_moves(o: &ModalObjective, before: &Outcome, x: &[f64]) -> String {
    let mut moves: Vec<(usize, f64)> = before
        .identified
        .iter()
        .map(|&i| (i, x[i] / before.x[i]))
        .filter(|(_, r)| r.is_finite() && *r > 0.0)
        .collect();
    moves.sort_by(|a, b| b.1.ln().abs().total_cmp(&a.1.ln().abs()));
    moves
        .iter()
        .take(MOVES_NAMED)
        .map(|&(i, r)| format!("{} ×{}", o.parameters()[i].name, sig(r, 3)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Identified parameters a refit's gain warning names by their move.
const MOVES_NAMED: usize = 3;

/// The refitted parameters `names` at `outcome`'s point, each judged for
/// plausibility ([`RefitValue`]): its ratio to the file value (`start`),
/// where it lies in its bounds and whether the data determine it there.
pub(super) fn refit_values(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    outcome: &Outcome,
    judged: &Judged,
    names: &[String],
) -> Vec<RefitValue> {
    let Ok(bounds) = o.bounds() else {
        return Vec::new();
    };
    let u = bounds.to_unit(&outcome.x);
    names
        .iter()
        .filter_map(|name| {
            let i = o.parameters().iter().position(|p| &p.name == name)?;
            let determined = outcome
                .identified
                .iter()
                .position(|&k| k == i)
                .and_then(|j| judged.identifiability.parameters.get(j))
                .is_some_and(|a| a.identifiable);
            Some(RefitValue::judge(
                name.clone(),
                outcome.x[i] / start[i],
                u[i],
                determined,
                plan.fixed_spread,
            ))
        })
        .collect()
}

/// A refit's refutation of the score test's implication: the parameters
/// it refuted and the warning that says so.
pub(super) struct Refutation {
    names: Vec<String>,
    warning: String,
}

/// Refute the score test's implication after a refit (judged `refitted`)
/// that did not fit better, or only slightly (`better`): `judged` goes back
/// to its untested verdict, with a warning saying so. The refutation, and
/// true when the fit is within the noise (then the follow-ups end).
fn refute(judged: &mut Judged, refitted: &Judged, better: bool) -> (Refutation, bool) {
    let (now, then) = (fit_rms(&judged.verdict), fit_rms(&refitted.verdict));
    let names = judged.verdict.implicated.join(", ");
    // The implication is refuted: within the noise it was
    // statistical, not practical (thousands of FRF lines make a tiny
    // structure significant); above it, the misfit is not theirs and
    // the escape search may tell a local minimum from model error.
    let within = judged.verdict.fit == Fit::WithinNoise;
    let how = if better {
        "fitted only slightly better"
    } else {
        "did not fit better"
    };
    let warning = format!(
        "the score test implicated {names}, but identifying them too {how} ({then:.2}σ against {now:.2}σ): {}",
        if within {
            "the fit is within the noise, not counted against the verdict"
        } else {
            "not taken, and the misfit is judged as not theirs"
        }
    );
    (refuted(judged, warning), within)
}

/// The refutation of `judged`'s implicated parameters with `warning`:
/// `judged` goes back to its untested verdict, with the warning.
fn refuted(judged: &mut Judged, warning: String) -> Refutation {
    let refutation = Refutation {
        names: std::mem::take(&mut judged.verdict.implicated),
        warning,
    };
    judged.verdict = judged.untested.clone();
    judged.verdict.warnings.push(refutation.warning.clone());
    refutation
}

/// Fits within the noise at most this RMS (σ units) cannot be refitted
/// materially better: a material gain needs a cost below [`ESCAPED`] of
/// before, an RMS 10 % lower, and no fit goes below the noise itself,
/// E[RMS²] = (N − p)/N ≈ 1 for N ≫ p residuals when the noise estimate is
/// right. The bound allows the estimate to be 5.5 % too large: the best
/// fits measured reach 0.945–0.96σ with noise from fourth differences and
/// 1.00–1.03σ with noise from coherence (test bench and mill families,
/// identify 32–33), and 0.945 / 0.9 = 1.05, less a margin. Of the 22 refits
/// that started within the noise below 1.11σ, none fitted better than 0.98
/// of its start (each cost 1,000–3,300 evaluations, a quarter of an
/// update).
const NOISE_FLOOR_BOUND: f64 = 1.04;

/// Whether a refit could fit materially better than a fit judged `fit`
/// with an FRF residual of `frf_rms` (σ units): not when it is within the
/// noise below [`NOISE_FLOOR_BOUND`]. Only FRFs have N ≫ p; a modal
/// residual of 50 values fitted by 20 parameters has E[RMS²] ≈ 0.6.
fn refit_can_gain(fit: Fit, frf_rms: Option<f64>) -> bool {
    !(fit == Fit::WithinNoise && frf_rms.is_some_and(|r| r <= NOISE_FLOOR_BOUND))
}

/// Refute the score test's implication without a refit, at a fit within
/// the noise that no refit can improve materially ([`refit_can_gain`]):
/// `judged` goes back to its untested verdict, with a warning saying so.
fn refute_at_floor(judged: &mut Judged) -> Refutation {
    let warning = format!(
        "the score test implicated {}, but the fit is {:.2}σ, at the noise floor (≤ {NOISE_FLOOR_BOUND}σ): identifying them too cannot fit materially better (10 % lower RMS) without fitting the noise, so it was not tried; not counted against the verdict",
        judged.verdict.implicated.join(", "),
        fit_rms(&judged.verdict)
    );
    refuted(judged, warning)
}

/// What a follow-up gained over the result before it, by the residual RMS
/// (σ units) of each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Gain {
    /// No lower RMS (or the follow-up's model could not be solved: NaN).
    None,
    /// Lower, but the cost not below [`ESCAPED`] of before (less than 10 %
    /// lower RMS).
    Slight,
    /// Cost below [`ESCAPED`] of before.
    Material,
}

impl Gain {
    /// A refit is taken only when its gain is material: one that gains
    /// little has spent its added parameters on the noise (they drift to
    /// their bounds, undetermined), and the simpler result stands (the
    /// screening kept them out for a reason). An escape start is taken
    /// whenever it fits better ([`escape`] keeps the better point itself).
    fn of(before: f64, after: f64) -> Gain {
        // NaN compares as never better.
        if !after.partial_cmp(&before).is_some_and(|o| o.is_lt()) {
            Gain::None
        } else if (after / before).powi(2) < ESCAPED {
            Gain::Material
        } else {
            Gain::Slight
        }
    }
}

/// Most window searches ([`super::super::window_search`]) in a row: each
/// one after the first runs only where the one before gained materially
/// and a window far above the noise is left — a sharp pair at one position
/// mended can leave its partner at the other misplaced by the compensation.
const WINDOW_SEARCHES: usize = 3;

/// Whether a window search is due after `done`, with `left` evaluations
/// of the budget, when a window far above the noise is left: none yet, or
/// the last follow-up was a window search that was taken and gained
/// materially, fewer than [`WINDOW_SEARCHES`] in all, and `left` pays
/// twice what it used — another like it and as much again for the refit
/// or escape after it. Without that a repeat took what the refit of the
/// implicated parameters needed where the budget is tight (the mill's
/// model-error family at 8,000: four fits ended at 1.8–3.3σ instead of the
/// refit's 1.5–2.6σ, which cost it 770–1,330 evaluations).
fn window_due(done: &[FollowUpRecord], left: usize) -> bool {
    let windows = window_searches(done);
    windows == 0
        || done.last().is_some_and(|f| {
            windows < WINDOW_SEARCHES
                && f.kind == FollowUpKind::Window
                && f.taken
                && Gain::of(f.rms_before, f.rms_after) == Gain::Material
                && left >= 2 * f.evaluations
        })
}

/// The window searches among the follow-ups `done`.
fn window_searches(done: &[FollowUpRecord]) -> usize {
    (done.iter())
        .filter(|f| f.kind == FollowUpKind::Window)
        .count()
}

/// Most implicated parameters one refit adds (largest statistics first).
const REFIT_AT_ONCE: usize = 3;

/// The residual RMS (σ units) a verdict is about: the FRFs' when given.
fn fit_rms(v: &Verdict) -> f64 {
    v.frf.map_or(v.end_rms, |f| f.end.rms)
}

/// The assessment and verdict of an [`Outcome`].
pub(super) struct Judged {
    pub(super) verdict: Verdict,
    /// The verdict before the score test's implicated parameters counted.
    untested: Verdict,
    pub(super) identifiability: Identifiability,
    pub(super) consider: Option<Consider>,
    pub(super) pairs: Vec<Vec<FinalPair>>,
    pub(super) evaluations: usize,
}

impl Judged {
    /// Keep a refit's refutation on this later judgement: the parameters
    /// it refuted are not implicated again (what else the score test
    /// implicates here is), and its warning stays.
    fn keep_refutation(&mut self, r: &Refutation) {
        let kept: Vec<Implication> = self.consider.as_ref().map_or(Vec::new(), |c| {
            c.implicated()
                .into_iter()
                .filter(|f| !r.names.contains(&f.parameter))
                .map(Implication::from)
                .collect()
        });
        self.untested.warnings.push(r.warning.clone());
        self.verdict = self.untested.clone().with_implicated(&kept);
    }

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
    // A window far above the noise: what the modal reference holds there.
    if let (Some(r), Some((reference, _))) = (&outcome.frf, plan.frf) {
        let far = r.summary.end.local.filter(|l| l.rms > LOCAL_NOISE_RMS);
        let note = far.and_then(|l| {
            let window = reference.window_hz(l.position, l.frequency_hz)?;
            Some(l.reference_note(o, window))
        });
        warnings.extend(note);
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
    let implicated: Vec<Implication> = consider.as_ref().map_or(Vec::new(), |c| {
        c.implicated().into_iter().map(Implication::from).collect()
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

#[cfg(test)]
mod tests;
