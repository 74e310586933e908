//! A search aimed at the resonance an FRF fit misses (issue 26): the worst
//! window of lines ([`super::local_misfit::LocalMisfit`]) far above the
//! noise while the overall fit is near it is a lightly damped mode, or a
//! close pair, the fit left in another basin — a few lines wide, so the
//! Levenberg–Marquardt steps of the refinement, which see the whole band,
//! do not climb out, and the escape search over the box of *every*
//! identified parameter samples its few relevant directions thinly (128
//! points in 40–50 dimensions on the vertical mill).
//!
//! Here the identified parameters that can mend that window are found
//! first: each is scanned alone over its box ([`SCAN`] points, the others
//! held) and the window's misfit power Σ_c |d_c|² over its lines
//! recomputed. Moved alone, such a parameter spoils what the others had
//! fitted around its wrong value, so the whole band is not judged there:
//! from the scan's best point of each of the [`PARAMETERS`] that lower the
//! window most, in turn, every identified parameter is refined on the FRFs
//! ([`super::frf_refinement`]), and the first result whose robust FRF cost
//! is below the update's replaces it.

use super::follow_up::{searched_step, EscapeEnd, Outcome, Step, ESCAPED, MINIMUM};
use super::frf_objective::FrfReference;
use super::frf_refinement::{frf_refinement, FrfRefinement};
use super::local_misfit::LocalMisfit;
use super::updating::Plan;
use super::verdict::SearchEvidence;
use super::{IdentifyError, ModalObjective};
use rayon::prelude::*;

/// Points of each parameter's scan over its box (the unit interval, ends
/// included): one line of the mill's 0.25 Hz spectrum is ~0.5 % of a
/// 54 Hz mode, and a parameter the modes barely see may need most of its
/// range to move such a mode by a few lines.
pub const SCAN: usize = 9;

/// Parameters whose scan's best point starts a refinement, best first.
pub const PARAMETERS: usize = 3;

/// A parameter that lowers the window's misfit when moved alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowMove {
    pub parameter: usize,
    /// Its value at the scan's best point.
    pub value: f64,
    /// How much that lowers the window's misfit power, as a fraction of it.
    pub gain: f64,
}

/// The identified parameters of `x` that lower the misfit power of `window`
/// (position, first and last line in Hz) most when moved alone over their
/// box ([`SCAN`] points, the others held), the [`PARAMETERS`] best first,
/// with the evaluations spent; `None` when the window's power cannot be
/// computed at `x`.
pub fn window_moves(
    o: &ModalObjective,
    reference: &FrfReference,
    x: &[f64],
    identified: &[usize],
    window: (u32, (f64, f64)),
) -> Result<Option<(Vec<WindowMove>, usize)>, IdentifyError> {
    let bounds = o.bounds()?;
    let (position, lines) = window;
    let power = |x: &[f64]| reference.window_power(o.prepared(), x, position, lines);
    let Some(p0) = power(x) else {
        return Ok(None);
    };
    let u = bounds.to_unit(x);
    // Each parameter's best scan point (a point the model cannot solve
    // counts as none). A local step would rank the parameters the window
    // is most sensitive to, which the fit has usually placed already; the
    // misplaced mode waits on one it barely sees (the mill's impact seed
    // 29: `nut.k_ry` at 3.1× its true value lowers the window by 94 % when
    // scanned, while the five largest local sensitivities are within
    // 0.4 % of the truth).
    let mut moves: Vec<WindowMove> = identified
        .par_iter()
        .map(|&i| {
            let mut best = (p0, x[i]);
            for k in 0..SCAN {
                let mut v = u.clone();
                v[i] = k as f64 / (SCAN - 1) as f64;
                let xk = bounds.to_physical(&v);
                if let Some(p) = power(&xk).filter(|&p| p < best.0) {
                    best = (p, xk[i]);
                }
            }
            WindowMove {
                parameter: i,
                value: best.1,
                gain: 1.0 - best.0 / p0,
            }
        })
        .collect();
    moves.retain(|m| m.gain > 0.0);
    moves.sort_by(|a, b| {
        b.gain
            .total_cmp(&a.gain)
            .then(a.parameter.cmp(&b.parameter))
    });
    moves.truncate(PARAMETERS);
    Ok(Some((moves, 1 + SCAN * identified.len())))
}

/// Search for the resonance of the worst window of `now`'s FRF fit
/// (`local`, above the noise): from each of the best [`window_moves`] in
/// turn, refine every identified parameter on the FRFs, within `budget`
/// (shared evenly by the starts still to run); the first that fits better
/// than `now` is the step's outcome. `None` without FRFs, a window or the
/// budget for the scan and one refinement; `now` unchanged (the scan's cost
/// accounted) when no parameter lowers the window.
pub(super) fn window_search(
    o: &ModalObjective,
    plan: &Plan,
    start: &[f64],
    now: &Outcome,
    local: LocalMisfit,
    budget: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Option<Step>, IdentifyError> {
    let Some((reference, settings)) = plan.frf.filter(|(_, s)| s.enabled) else {
        return Ok(None);
    };
    let Some(before) = now.frf.as_ref().map(|r| r.summary.end) else {
        return Ok(None);
    };
    let one_run = MINIMUM.max(8 * (now.identified.len() + 1));
    if budget < 1 + SCAN * now.identified.len() + one_run {
        return Ok(None);
    }
    let Some(lines) = reference.window_hz(local.position, local.frequency_hz) else {
        return Ok(None);
    };
    let Some((moves, mut cost)) = window_moves(
        o,
        reference,
        &now.x,
        &now.identified,
        (local.position, lines),
    )?
    else {
        return Ok(None);
    };
    let bounds = o.bounds()?;
    let mut best: Option<FrfRefinement> = None;
    for (k, m) in moves.iter().enumerate() {
        // An even share of what is left, or all of it when a share would
        // be too small for a refinement.
        let left = budget.saturating_sub(cost);
        let share = match left / (moves.len() - k) {
            s if s >= one_run => s,
            _ if left >= one_run => left,
            _ => break,
        };
        let mut x0 = now.x.clone();
        x0[m.parameter] = m.value;
        let r = match frf_refinement(
            o.prepared(),
            &bounds,
            reference,
            &now.identified,
            &[],
            &x0,
            start,
            share,
            settings,
            plan.seed,
            progress,
        ) {
            Err(IdentifyError::Invalid(_)) => continue,
            r => r?,
        };
        cost += r.summary.evaluations;
        let won = r.summary.end.robust_cost < before.robust_cost;
        if best
            .as_ref()
            .is_none_or(|b| r.summary.end.robust_cost < b.summary.end.robust_cost)
        {
            best = Some(r);
        }
        if won {
            break;
        }
    }
    // The scan was paid for even when no refinement could follow: the
    // step leaves `now` as it was and says so.
    let Some(r) = best else {
        return Ok(Some(Step {
            outcome: now.clone(),
            cost,
            escape: Some(EscapeEnd {
                rms: before.rms,
                better: false,
            }),
        }));
    };
    // A better basin found is evidence of a local minimum; finding none is
    // no evidence either way (a few directions were tried).
    let evidence = if r.summary.end.robust_cost < ESCAPED * before.robust_cost {
        SearchEvidence {
            escaped: Some(true),
            short: None,
        }
    } else {
        now.evidence
    };
    Ok(Some(searched_step(now, r, evidence, now.searched, cost)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::black_box::tests::{objective, truth};
    use crate::identify::follow_up::tests::{chain_reference, frf_plan, stalled_at, stuck_at};
    use crate::identify::frf_refinement::FrfRefinementParams;

    /// A planted misplaced resonance: the three-mass chain's FRFs at 1 %
    /// noise, fitted with `k3.k_x` held at 2.2× its true value (the others
    /// compensate, as a basin the refinement does not leave): the worst
    /// window is far above the noise. The scan puts `k3.k_x` among the
    /// parameters that mend the window, and the refinement from its best
    /// point brings the fit to the noise with `k3.k_x` at its true value,
    /// within its budget, as evidence of a local minimum.
    #[test]
    fn a_planted_misplaced_resonance_is_found_by_its_window() {
        let o = objective();
        // k3.k_x's true value on a point of its scan (the middle of its log
        // range): a 9-point scan finds a sharp resonance only near one.
        let mut t = truth();
        t[3] = (1.2e5f64 * 2.0e6).sqrt();
        let r = chain_reference(&t);
        let settings = FrfRefinementParams::default();
        let mut x0 = t.clone();
        x0[3] *= 2.2;
        let held: Vec<usize> = (0..8).filter(|&i| i != 3).collect();
        let stuck = stuck_at(&r, &held, &x0, &settings);
        let local = stuck.summary.end.local.unwrap();
        assert!(local.rms > 10.0, "{:?}", stuck.summary.end);
        let all: Vec<usize> = (0..8).collect();
        let lines = r.window_hz(local.position, local.frequency_hz).unwrap();
        let (moves, cost) = window_moves(&o, &r, &stuck.x, &all, (local.position, lines))
            .unwrap()
            .unwrap();
        assert_eq!(cost, 1 + SCAN * 8);
        assert!(moves.len() <= PARAMETERS && !moves.is_empty());
        assert!(
            moves.windows(2).all(|w| w[0].gain >= w[1].gain),
            "{moves:?}"
        );
        assert!(
            moves.iter().all(|m| m.gain > 0.0 && m.gain <= 1.0),
            "{moves:?}"
        );
        assert!(moves.iter().any(|m| m.parameter == 3), "{moves:?}");
        let optimizer = crate::optimize::Optimizer::from_settings("slsqp", None).unwrap();
        let plan = frf_plan(&r, &settings, &optimizer);
        let now = stalled_at(stuck);
        let step = window_search(&o, &plan, &o.nominal(), &now, local, 3000, &|_| {})
            .unwrap()
            .unwrap();
        assert!(step.cost <= 3000, "{}", step.cost);
        let end = step.escape.unwrap();
        assert!(end.better);
        let next = step.outcome;
        assert_eq!(next.evidence.escaped, Some(true));
        assert!(!next.searched, "the escape over every box is still to run");
        let fit = next.frf.as_ref().unwrap().summary.end;
        assert!(fit.rms < 1.1, "{fit:?}");
        assert_eq!(fit.rms, end.rms);
        assert!(
            (next.x[3] / t[3] - 1.0).abs() < 0.01,
            "{}",
            next.x[3] / t[3]
        );
        // No budget for the search: nothing runs.
        assert!(
            window_search(&o, &plan, &o.nominal(), &now, local, 100, &|_| {})
                .unwrap()
                .is_none()
        );
    }
}
