//! Step 2 of the guided strategy, the refinement (module docs of
//! [`super`]): continuation runs over the stiffness parameters from the
//! better of the start and the subproblems' values, then, while the best fit
//! is above the noise, from the other and from scrambled-Sobol points; the
//! best run is kept unless it ends worse than the start.

use super::super::continuation::{
    continuation, minimum_budget, termination_text, ContinuationResult,
};
use super::super::history::Recorder;
use super::super::verdict::{Status, NOISE_RMS};
use super::super::{IdentifyError, ModalObjective};
use super::{GuidedParams, RefinementRun};

/// What the refinement runs found.
pub(super) struct Refined {
    pub(super) x: Vec<f64>,
    pub(super) status: Status,
    pub(super) evaluations: usize,
    pub(super) runs: Vec<RefinementRun>,
}

/// The budget one refinement run over `n` parameters needs: what the
/// continuation needs (all its stages), and no less than 8 per parameter.
pub(super) fn run_minimum(o: &ModalObjective, n: usize, settings: &GuidedParams) -> usize {
    (8 * (n + 1)).max(minimum_budget(o, n, &settings.continuation))
}

/// Step 2 over the parameters `free` (indices) from `start` (all values).
pub(super) struct Refinement<'a> {
    pub(super) o: &'a ModalObjective,
    pub(super) free: &'a [usize],
    pub(super) start: &'a [f64],
    pub(super) settings: &'a GuidedParams,
    pub(super) seed: u64,
    pub(super) recorder: &'a Recorder,
    pub(super) progress: &'a (dyn Fn(u64) + Sync),
}

/// A named start point of a run (`start`, `subproblems` or `sobol <k>`)
/// and its values.
type Candidate = (String, Vec<f64>);

/// The runs of step 2 so far.
struct Runs {
    /// The best run's result and its index in `runs`.
    best: Option<(ContinuationResult, usize)>,
    runs: Vec<RefinementRun>,
}

impl Refinement<'_> {
    /// Step 2: continuation runs from the better of `start` and `x1`, then,
    /// while the best fit is above the noise, from the other and from Sobol
    /// points, with at most `budget` evaluations.
    pub(super) fn refine(&self, x1: &[f64], budget: usize) -> Result<Refined, IdentifyError> {
        let (o, start, progress) = (self.o, self.start, self.progress);
        let usable = o.usable();
        let cost = |x: &[f64]| {
            o.evaluate(x, &usable)
                .map_or(f64::INFINITY, |e| e.robust_usable)
        };
        let (candidates, mut used) = self.candidates(x1, &cost)?;
        let residual_count = o
            .evaluate(start, &usable)
            .map_or(1, |e| e.residuals.len().max(1));
        used += 1;
        progress(1);
        let noise_cost = 0.5 * NOISE_RMS * NOISE_RMS * residual_count as f64;
        // A later start below a run's minimum is skipped.
        let minimum = run_minimum(o, self.free.len(), self.settings);
        let Runs { best, mut runs } =
            self.run_candidates(&candidates, budget, minimum, noise_cost, &mut used)?;
        // The subproblems may leave less than one run needs (the up-front
        // check cannot know what they will use): the better start stands,
        // and the verdict names the budget instead of refusing the stage.
        let Some((r, index)) = best else {
            return Ok(Refined {
                x: candidates[0].1.clone(),
                status: Status::BudgetExhausted,
                evaluations: used,
                runs,
            });
        };
        let kept = runs.remove(index);
        runs.insert(0, kept);
        // Never worse than where it started: when every run ends above the
        // start's cost, the start stands (and the verdict says it stalled).
        let start_cost = cost(start);
        used += 1;
        progress(1);
        let improved = r.end_cost.partial_cmp(&start_cost) != Some(std::cmp::Ordering::Greater)
            && r.end_cost.is_finite();
        if !improved {
            return Ok(Refined {
                x: start.to_vec(),
                status: Status::Stalled,
                evaluations: used,
                runs,
            });
        }
        Ok(Refined {
            x: r.x,
            status: Status::of(&r.termination),
            evaluations: used,
            runs,
        })
    }

    /// The start points of the runs, named, in the order they are tried: the
    /// better (by `cost`) of `start` and `x1` first, then the other, then
    /// Sobol points of the box, `restarts + 1` in all; and the evaluations
    /// spent choosing.
    fn candidates(
        &self,
        x1: &[f64],
        cost: &dyn Fn(&[f64]) -> f64,
    ) -> Result<(Vec<Candidate>, usize), IdentifyError> {
        let (start, settings, seed) = (self.start, self.settings, self.seed);
        let mut used = 0;
        let mut candidates: Vec<Candidate> = vec![("start".into(), start.to_vec())];
        if x1 != start {
            let (c0, c1) = (cost(start), cost(x1));
            used += 2;
            (self.progress)(2);
            let sub = ("subproblems".to_string(), x1.to_vec());
            if c1 < c0 {
                candidates.insert(0, sub);
            } else {
                candidates.push(sub);
            }
        }
        let bounds = self.o.bounds()?;
        for k in 1..=settings.restarts {
            let point = bounds.sobol_point(
                start,
                self.free,
                k as u32,
                seed as u32 ^ (seed >> 32) as u32,
            );
            candidates.push((format!("sobol {k}"), point));
        }
        candidates.truncate(settings.restarts + 1);
        Ok((candidates, used))
    }

    /// A continuation run from each of `candidates` in turn, the first with
    /// most of what is left of `budget` and later ones sharing the rest,
    /// until a run ends within the noise (`noise_cost`) or a share falls
    /// below `minimum`; `used` counts the evaluations.
    fn run_candidates(
        &self,
        candidates: &[Candidate],
        budget: usize,
        minimum: usize,
        noise_cost: f64,
        used: &mut usize,
    ) -> Result<Runs, IdentifyError> {
        let mut best: Option<(ContinuationResult, usize)> = None;
        let mut runs = Vec::new();
        for (k, (from, x0)) in candidates.iter().enumerate() {
            let left = budget.saturating_sub(*used);
            let runs_left = candidates.len() - k;
            // The first run may use most of it; later ones share what is left.
            let share = if k == 0 && runs_left > 1 {
                // ... but never less than one run when the budget has it.
                (left * 3 / 5).max(minimum.min(left))
            } else {
                left / runs_left
            };
            if share < minimum {
                break;
            }
            let r = continuation(
                self.o,
                self.free,
                x0,
                self.start,
                share.max(minimum),
                &self.settings.continuation,
                self.recorder,
                self.progress,
            )?;
            *used += r.evaluations;
            runs.push(RefinementRun::of(from, &r));
            let better = best.as_ref().is_none_or(|(b, _)| r.end_cost < b.end_cost);
            if better {
                best = Some((r, runs.len() - 1));
            }
            if best.as_ref().is_some_and(|(b, _)| b.end_cost <= noise_cost) {
                break;
            }
        }
        Ok(Runs { best, runs })
    }
}

impl RefinementRun {
    /// The record of continuation run `r`, started from `from`.
    fn of(from: &str, r: &ContinuationResult) -> RefinementRun {
        RefinementRun {
            from: from.to_string(),
            stages: r.stages.clone(),
            outliers: r.outliers.clone(),
            evaluations: r.evaluations,
            termination: termination_text(&r.termination),
            start: r.start_cost,
            end: r.end_cost,
        }
    }
}
