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

use super::continuation::ContinuationParams;
use super::correspondence::{Correspondence, NamedMode};
use super::history::{HistoryRow, Recorder};
use super::subproblem::{
    decompose, solve, Decomposition, SolveSettings, Starts, SubproblemRun, SubproblemSpec,
};
use super::verdict::Status;
use super::{identify_damping, IdentifyError, ModalObjective};
use crate::optimize::slsqp::SlsqpParams;
use refinement::{run_minimum, Refined, Refinement};
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
    let d = screened_subproblems(o, c, screening)?;
    let stiffness = refined_stiffness(o, &d, screening.significant);
    let shares = Shares::of(o, &d, stiffness.len(), settings, budget)?;
    // Step 1: the subproblems.
    let solve_settings = SolveSettings {
        slsqp: slsqp_params,
        repeats: settings.repeats,
        budget: shares.per_run,
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
    let (x1, chosen) = choose_values(o, &stiffness, &runs, start, settings.spread_limit);
    // Step 2: the refinement.
    let recorder = Recorder::starting_at(step1);
    let refined = if settings.refine {
        let left = budget.saturating_sub(step1 + shares.damping);
        let refinement = Refinement {
            o,
            free: &stiffness,
            start,
            settings,
            seed,
            recorder: &recorder,
            progress,
        };
        refinement.refine(&x1, left)?
    } else {
        Refined {
            x: x1,
            status: Status::Converged,
            evaluations: 0,
            runs: Vec::new(),
        }
    };
    let (step2, status, refinement) = (refined.evaluations, refined.status, refined.runs);
    // Step 3: the damping.
    let mut x = refined.x;
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

/// The subproblems of `screening` ([`decompose`]); an error naming the
/// first reasons when none is left to solve.
fn screened_subproblems(
    o: &ModalObjective,
    c: &Correspondence,
    screening: Screening,
) -> Result<Decomposition, IdentifyError> {
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
    Ok(d)
}

/// The stiffness parameters the strategy identifies (indices, ascending):
/// those of the subproblems and every other one the screening lists as
/// `significant`.
fn refined_stiffness(
    o: &ModalObjective,
    d: &Decomposition,
    significant: Option<&[String]>,
) -> Vec<usize> {
    // The refinement moves every significant stiffness parameter, not only
    // those of subproblems with a reference mode: the other modes may still
    // determine them (the identifiability analysis says whether), and one
    // left at a wrong start value biases its partners.
    let mut stiffness = d.stiffness();
    if let Some(sig) = significant {
        stiffness.extend(o.parameters().iter().enumerate().filter_map(|(i, p)| {
            (p.kind == crate::dynamics::ParameterKind::Stiffness && sig.contains(&p.name))
                .then_some(i)
        }));
        stiffness.sort_unstable();
        stiffness.dedup();
    }
    stiffness
}

/// How the budget is shared between the steps (module docs).
struct Shares {
    /// Evaluations of the damping fit.
    damping: usize,
    /// Evaluations of one SLSQP run of a subproblem.
    per_run: usize,
}

impl Shares {
    /// The shares of `budget` for the subproblems of `d` and a refinement
    /// over `n` parameters; an error when the budget is below what they need.
    fn of(
        o: &ModalObjective,
        d: &Decomposition,
        n: usize,
        settings: &GuidedParams,
        budget: usize,
    ) -> Result<Shares, IdentifyError> {
        let damping_cost = super::damping::evaluations(d.damping.len());
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
        Ok(Shares {
            damping: damping_cost,
            per_run: settings
                .subproblem_budget
                .min(share / runs_total.max(1))
                .max(2),
        })
    }
}

/// Step 1's values: each `stiffness` parameter takes its mean from the
/// subproblem run in which it varied least, when that spread is at most
/// `spread_limit`, else keeps its `start` value. Returns all values and
/// where each came from.
fn choose_values(
    o: &ModalObjective,
    stiffness: &[usize],
    runs: &[SubproblemRun],
    start: &[f64],
    spread_limit: f64,
) -> (Vec<f64>, Vec<Choice>) {
    let params = o.parameters();
    let mut x1 = start.to_vec();
    let mut chosen = Vec::new();
    for &i in stiffness {
        let p = &params[i];
        let best = runs
            .iter()
            .filter_map(|r| {
                let j = r.parameters.iter().position(|n| *n == p.name)?;
                Some((r, j, r.spread[j]))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2));
        let taken = best.is_some_and(|(_, _, s)| s <= spread_limit);
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
    (x1, chosen)
}

mod refinement;

#[cfg(test)]
mod tests;
