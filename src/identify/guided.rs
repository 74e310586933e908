//! The sensitivity-guided strategy (PUB3, seed section 5.2.3) in three steps:
//!
//! 1. **Subproblems** ([`super::subproblem`]): per mode-shape reference of a
//!    GSA screening, SLSQP over its significant stiffness parameters on the
//!    mode's own criterion, the other parameters at seeded random values,
//!    repeated `repeats` times. Each stiffness parameter takes its value (the
//!    mean over the repeats, in its scale) from the subproblem in which it
//!    varied least — provided that spread is at most `spread_limit`;
//!    otherwise no subproblem determines it and it keeps its start value.
//! 2. **Refinement** (`refine`, on by default): all stiffness parameters of
//!    the subproblems together by the mode-set continuation
//!    ([`super::continuation`]): bounded Levenberg–Marquardt on the weighted
//!    modal residuals, the lowest modes first. It starts from the step-1
//!    values or from the start values, whichever fits the reference better
//!    (a subproblem sees one mode with the rest of the model at random
//!    values, so its answer can be worse than the start). When the fit ends
//!    above the reference's noise, up to `restarts` further runs start from
//!    the other of the two and then from scrambled-Sobol points of the
//!    parameter box; the best fit is kept. The parameters in no subproblem
//!    stay at their start values.
//! 3. **Damping** ([`super::damping`]): the damping parameters named by the
//!    damping outputs of the screening, by bounded linear least squares at
//!    the identified stiffness (modal damping is linear in them); the other
//!    damping parameters keep their start values.
//!
//! The budget caps all model evaluations: step 1 gets at most
//! `subproblem_share` of it (each SLSQP run at most `subproblem_budget`),
//! the damping fit 1 + its parameters, step 2 the rest. The history records
//! step 2's improvements of ½‖r‖² over all usable modes with the mean MAC
//! reached (evaluations counted from the start of step 1).

use super::continuation::{continuation, ContinuationParams, ContinuationResult};
use super::correspondence::{Correspondence, NamedMode};
use super::history::{HistoryRow, Recorder};
use super::subproblem::{decompose, solve, SolveSettings, Starts, SubproblemRun, SubproblemSpec};
use super::verdict::{Status, NOISE_RMS};
use super::{identify_damping, IdentifyError, ModalObjective};
use crate::optimize::slsqp::SlsqpParams;
use serde::{Deserialize, Serialize};

/// Settings of the guided strategy (YAML `guided:` of an identify stage).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct GuidedParams {
    /// SLSQP runs per subproblem (PUB3's repeats); 0 skips step 1.
    pub repeats: usize,
    /// Evaluations per SLSQP run of a subproblem.
    pub subproblem_budget: usize,
    /// Largest share of the budget step 1 may use.
    pub subproblem_share: f64,
    /// Largest spread over the repeats (std of ln value) at which a
    /// subproblem's value is taken.
    pub spread_limit: f64,
    /// Step 2, the joint refinement.
    pub refine: bool,
    /// Further refinement runs when a fit ends above the noise.
    pub restarts: usize,
    /// Smoothing δ of NFD in the subproblem criterion (pseudo-Huber).
    pub smoothing: f64,
    /// Where the repeats put the parameters outside the subproblem.
    pub others: Starts,
    /// The continuation of step 2.
    pub continuation: ContinuationParams,
}

impl Default for GuidedParams {
    fn default() -> Self {
        GuidedParams {
            repeats: 3,
            subproblem_budget: 200,
            subproblem_share: 0.25,
            spread_limit: 0.05,
            refine: true,
            restarts: 3,
            smoothing: 1e-3,
            others: Starts::Random,
            continuation: ContinuationParams::default(),
        }
    }
}

impl GuidedParams {
    /// Check the settings; the message names the bad one.
    pub fn check(&self) -> Result<(), String> {
        if self.subproblem_budget < 2 {
            return Err("subproblem_budget must be at least 2".into());
        }
        if !(self.subproblem_share > 0.0 && self.subproblem_share < 1.0) {
            return Err(format!(
                "subproblem_share must be in (0, 1), got {}",
                self.subproblem_share
            ));
        }
        if !(self.spread_limit >= 0.0 && self.spread_limit.is_finite()) {
            return Err(format!(
                "spread_limit must be finite and ≥ 0, got {}",
                self.spread_limit
            ));
        }
        if !(self.smoothing >= 0.0 && self.smoothing.is_finite()) {
            return Err(format!(
                "smoothing must be finite and ≥ 0, got {}",
                self.smoothing
            ));
        }
        self.continuation.check()
    }
}

/// The GSA screening the strategy is guided by.
#[derive(Clone, Copy, Debug)]
pub struct Screening<'a> {
    /// Per output its significant parameters (subproblems.json).
    pub specs: &'a [SubproblemSpec],
    /// The screening's significant parameters, if it lists them.
    pub significant: Option<&'a [String]>,
    /// The frequencies of the modes the screening named.
    pub modes: &'a [NamedMode],
}

/// Where a stiffness parameter's step-1 value came from.
#[derive(Clone, Debug, Serialize)]
pub struct Choice {
    pub parameter: String,
    /// The subproblem with the least spread (`None`: in no subproblem).
    pub subproblem: Option<String>,
    pub spread: Option<f64>,
    /// True when that value was taken (spread ≤ spread_limit).
    pub taken: bool,
    pub value: f64,
}

/// One run of the refinement.
#[derive(Clone, Debug, Serialize)]
pub struct RefinementRun {
    /// Where it started: `start`, `subproblems` or `sobol <k>`.
    pub from: String,
    pub stages: Vec<super::continuation::StageRecord>,
    /// Modes it down-weighted as outliers.
    pub outliers: Vec<super::continuation::Outlier>,
    pub evaluations: usize,
    pub termination: String,
    /// The robust cost over all usable modes at its start and end.
    pub start: f64,
    pub end: f64,
}

/// The result of the guided strategy.
#[derive(Clone, Debug, Serialize)]
pub struct GuidedResult {
    pub x: Vec<f64>,
    pub evaluations: usize,
    /// Evaluations of step 1, step 2 and the damping fit.
    pub phase_evaluations: [usize; 3],
    pub subproblems: Vec<SubproblemRun>,
    pub skipped: Vec<(String, String)>,
    pub chosen: Vec<Choice>,
    /// The refinement runs, the kept one first.
    pub refinement: Vec<RefinementRun>,
    /// The stiffness parameters identified (indices).
    pub stiffness: Vec<usize>,
    /// How the kept refinement ended.
    pub status: Status,
    pub history: Vec<HistoryRow>,
    /// Damping parameters fitted (indices).
    pub damping: Vec<usize>,
    pub damping_equations: usize,
    pub damping_rms_residual: f64,
}

/// Run the guided strategy on `screening` from `start` (all parameter
/// values) with at most `budget` evaluations; `c` pairs the screening's
/// modes with the reference; `progress` gets the size of every batch.
#[allow(clippy::too_many_arguments)]
pub fn guided(
    o: &ModalObjective,
    c: &Correspondence,
    screening: Screening,
    settings: &GuidedParams,
    slsqp_params: &SlsqpParams,
    start: &[f64],
    budget: usize,
    seed: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<GuidedResult, IdentifyError> {
    settings.check().map_err(IdentifyError::Invalid)?;
    let params = o.parameters();
    let d = decompose(
        o,
        c,
        screening.modes,
        screening.specs,
        screening.significant,
    )?;
    if d.subproblems.is_empty() {
        let why: Vec<String> = d
            .skipped
            .iter()
            .take(3)
            .map(|(o, w)| format!("{o}: {w}"))
            .collect();
        return Err(IdentifyError::Invalid(format!(
            "no subproblem has a significant stiffness parameter and a usable reference mode ({}); check the gsa threshold, `exclude_modes` and `positions`",
            why.join("; ")
        )));
    }
    // The refinement moves every significant stiffness parameter, not only
    // those of subproblems with a reference mode: the other modes may still
    // determine them (the identifiability analysis says whether), and one
    // left at a wrong start value biases its partners.
    let mut stiffness = d.stiffness();
    if let Some(sig) = screening.significant {
        stiffness.extend(params.iter().enumerate().filter_map(|(i, p)| {
            (p.kind == crate::dynamics::ParameterKind::Stiffness && sig.contains(&p.name))
                .then_some(i)
        }));
        stiffness.sort_unstable();
        stiffness.dedup();
    }
    let damping_cost = super::damping::evaluations(d.damping.len());
    let n = stiffness.len();
    let runs_total = d.subproblems.len() * settings.repeats;
    let share = if settings.refine {
        (budget as f64 * settings.subproblem_share) as usize
    } else {
        budget.saturating_sub(damping_cost)
    };
    let minimum = damping_cost
        + 2 * runs_total
        + if settings.refine {
            run_minimum(o, n, settings)
        } else {
            0
        };
    if budget < minimum {
        return Err(IdentifyError::Invalid(format!(
            "budget {budget} is too small for {} subproblems × {} repeats{}; give at least {minimum}",
            d.subproblems.len(),
            settings.repeats,
            if settings.refine { " and the refinement" } else { "" },
        )));
    }
    // Step 1: the subproblems.
    let solve_settings = SolveSettings {
        slsqp: slsqp_params,
        repeats: settings.repeats,
        budget: settings
            .subproblem_budget
            .min(share / runs_total.max(1))
            .max(2),
        delta: settings.smoothing,
        starts: settings.others,
        seed,
    };
    let mut runs = Vec::with_capacity(d.subproblems.len());
    if settings.repeats > 0 {
        for (k, sub) in d.subproblems.iter().enumerate() {
            runs.push(solve(o, sub, k, start, &solve_settings, progress)?);
        }
    }
    let step1: usize = runs.iter().map(|r| r.evaluations).sum();
    let mut x1 = start.to_vec();
    let mut chosen = Vec::new();
    for &i in &stiffness {
        let p = &params[i];
        let best = runs
            .iter()
            .filter_map(|r| {
                let j = r.parameters.iter().position(|n| *n == p.name)?;
                Some((r, j, r.spread[j]))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2));
        let taken = best.is_some_and(|(_, _, s)| s <= settings.spread_limit);
        if let (true, Some((r, j, _))) = (taken, best) {
            x1[i] = r.mean[j];
        }
        chosen.push(Choice {
            parameter: p.name.clone(),
            subproblem: best.map(|(r, _, _)| r.name.clone()),
            spread: best.map(|b| b.2),
            taken,
            value: x1[i],
        });
    }
    // Step 2: the refinement.
    let recorder = Recorder::starting_at(step1);
    let mut x = x1.clone();
    let mut refinement = Vec::new();
    let mut status = Status::Converged;
    let mut step2 = 0;
    if settings.refine {
        let left = budget.saturating_sub(step1 + damping_cost);
        let r = refine(
            o, &stiffness, start, &x1, settings, left, seed, &recorder, progress,
        )?;
        step2 = r.evaluations;
        x = r.x;
        status = r.status;
        refinement = r.runs;
    }
    // Step 3: the damping.
    let (mut eq, mut rms, mut step3) = (0, 0.0, 0);
    if !d.damping.is_empty() {
        let fit = identify_damping(o, &x, &d.damping)?;
        progress(fit.evaluations as u64);
        step3 = fit.evaluations;
        x = fit.x;
        eq = fit.equations;
        rms = fit.rms_residual;
    }
    Ok(GuidedResult {
        evaluations: step1 + step2 + step3,
        phase_evaluations: [step1, step2, step3],
        subproblems: runs,
        skipped: d.skipped,
        chosen,
        refinement,
        stiffness,
        status,
        history: recorder.rows(),
        damping: d.damping,
        damping_equations: eq,
        damping_rms_residual: rms,
        x,
    })
}

/// What the refinement runs found.
struct Refined {
    x: Vec<f64>,
    status: Status,
    evaluations: usize,
    runs: Vec<RefinementRun>,
}

/// The budget one refinement run over `n` parameters needs: what the
/// continuation needs (all its stages), and no less than 8 per parameter.
fn run_minimum(o: &ModalObjective, n: usize, settings: &GuidedParams) -> usize {
    (8 * (n + 1)).max(super::continuation::minimum_budget(
        o,
        n,
        &settings.continuation,
    ))
}

/// Step 2: continuation runs from the better of `start` and `x1`, then, while
/// the best fit is above the noise, from the other and from Sobol points.
#[allow(clippy::too_many_arguments)]
fn refine(
    o: &ModalObjective,
    free: &[usize],
    start: &[f64],
    x1: &[f64],
    settings: &GuidedParams,
    budget: usize,
    seed: u64,
    recorder: &Recorder,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Refined, IdentifyError> {
    let usable = o.usable();
    let cost = |x: &[f64]| {
        o.evaluate(x, &usable)
            .map_or(f64::INFINITY, |e| e.robust_usable)
    };
    let mut used = 0;
    let mut candidates: Vec<(String, Vec<f64>)> = vec![("start".into(), start.to_vec())];
    if x1 != start {
        let (c0, c1) = (cost(start), cost(x1));
        used += 2;
        progress(2);
        let sub = ("subproblems".to_string(), x1.to_vec());
        if c1 < c0 {
            candidates.insert(0, sub);
        } else {
            candidates.push(sub);
        }
    }
    let bounds = o.bounds()?;
    for k in 1..=settings.restarts {
        let point = bounds.sobol_point(start, free, k as u32, seed as u32 ^ (seed >> 32) as u32);
        candidates.push((format!("sobol {k}"), point));
    }
    candidates.truncate(settings.restarts + 1);
    let residual_count = o
        .evaluate(start, &usable)
        .map_or(1, |e| e.residuals.len().max(1));
    used += 1;
    progress(1);
    let noise_cost = 0.5 * NOISE_RMS * NOISE_RMS * residual_count as f64;
    let mut best: Option<(ContinuationResult, usize)> = None;
    let mut runs = Vec::new();
    // A later start below a run's minimum is skipped.
    let minimum = run_minimum(o, free.len(), settings);
    for (k, (from, x0)) in candidates.iter().enumerate() {
        let left = budget.saturating_sub(used);
        let runs_left = candidates.len() - k;
        // The first run may use most of it; later ones share what is left.
        let share = if k == 0 && runs_left > 1 {
            left * 3 / 5
        } else {
            left / runs_left
        };
        if share < minimum {
            break;
        }
        let r = continuation(
            o,
            free,
            x0,
            start,
            share.max(minimum),
            &settings.continuation,
            recorder,
            progress,
        )?;
        used += r.evaluations;
        runs.push(RefinementRun {
            from: from.clone(),
            stages: r.stages.clone(),
            outliers: r.outliers.clone(),
            evaluations: r.evaluations,
            termination: super::continuation::termination_text(&r.termination),
            start: r.start_cost,
            end: r.end_cost,
        });
        let better = best.as_ref().is_none_or(|(b, _)| r.end_cost < b.end_cost);
        if better {
            best = Some((r, runs.len() - 1));
        }
        if best.as_ref().is_some_and(|(b, _)| b.end_cost <= noise_cost) {
            break;
        }
    }
    let Some((r, index)) = best else {
        return Err(IdentifyError::Invalid(format!(
            "budget {budget} cannot pay one refinement over {} parameters; give at least {minimum} more",
            free.len()
        )));
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

#[cfg(test)]
mod tests;
