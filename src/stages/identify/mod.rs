//! The `identify` kind: model updating against reference modes (seed section
//! 2.2; PUB3 section 5.2.3, PUB4 section 5.3) — see [`crate::identify`].
//!
//! The model is a synthesize `model` artifact (model.json, the model file's
//! text embedded) or a model file named by the `model` param (hashed with the
//! files it references); the reference is a `modes` artifact; the guided
//! strategy also reads a gsa `subproblems` artifact (subproblems.json).
//!
//! Outputs: `parameters` (parameters.csv with identifiability, standard
//! errors and 95 % intervals), `history` (history.csv:
//! `evaluation,best_objective,mean_mac`), `updated_modes` (the model's modes
//! at the identified values, at the reference DOFs; with FRFs every mode up
//! to the top of their band), `cost` (cost.json:
//! evaluations, seconds, the match and the verdict, [`crate::artifacts::cost::Cost`]),
//! `correlation` (correlation.csv: every reference mode, its partner and
//! why it is used or left out), `identifiability` (identifiability.json),
//! and for `sensitivity_guided` also `subproblems` (per subproblem: repeats,
//! values, spread; per parameter the subproblem it came from; the
//! refinement runs and stages; the damping fit).

mod inputs;
mod outputs;
mod params;
mod spec;
mod updated_model;

use super::{
    Artifact, FileRef, InputSpec, Kind, Output, ParamProblem, StageContext, StageError,
    StageOutputs,
};
use crate::artifacts;
use crate::artifacts::cost::{Cost, Phases};
use crate::identify::updating::{update, Plan, Strategy, Update};
use crate::identify::{IdentifyError, ModalObjective, Screening};
use crate::optimize::slsqp::SlsqpParams;
use crate::optimize::Optimizer;
use inputs::{load_model, ScreeningInput};
use outputs::write;
use params::problem;
pub use params::Params;
pub use spec::Checked;
use spec::Spec;
use std::path::Path;
use std::time::Instant;

pub struct Identify;

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "model",
        required: false,
        list: false,
        artifact: Artifact::Model,
        doc: "a synthesize `model` artifact (model.json); or give the `model` param",
    },
    InputSpec {
        name: "reference",
        required: true,
        list: false,
        artifact: Artifact::Modes,
        doc: "reference modes (a `modes` artifact)",
    },
    InputSpec {
        name: "sensitivity",
        required: false,
        list: false,
        artifact: Artifact::Subproblems,
        doc: "sensitivity_guided: a gsa `subproblems` artifact",
    },
    InputSpec {
        name: "frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "the measured FRFs the reference modes came from: the last step refines the identified parameters on them",
    },
];

impl Kind for Identify {
    /// The params and the [`Spec`] they describe, derived once when they
    /// are parsed (which reports every problem of either).
    type Params = Checked;
    const NAME: &'static str = "identify";
    const FILE_PARAMS: &'static [(&'static str, bool)] = &[("model", false)];

    /// 8: the `updated_model` output (the identified values in the model
    /// file). 9: model modes by shift-invert block Lanczos (issue 16).
    /// 10: the `frf` input and the FRF refinement.
    /// 11: per-line FRF noise from coherence (`frf_averages`), the noise
    /// model in cost.json, a warning for coherence left unused.
    /// 12: eigenpairs from the faster Lanczos (issue 16), last bits.
    /// 13: updated_modes' modes.csv always has the position columns
    /// (issue 31); uncalibrated FRFs and reference modes without damping
    /// are refused; the verdict names the reference modes left without a
    /// model partner (modes the model does not contain).
    /// 14: eigenpairs from the problem-chosen shift and range start of the
    /// Lanczos (issue 32).
    /// 15: consider covariance of the fixed parameters in the intervals,
    /// their score tests, refit of implicated ones, the escape search, the
    /// verdict's cause (issue 26).
    /// 16: artifacts through their schemas (issue 28): parameters.csv says
    /// `std_error_rel`, `std_error_with_fixed_rel`, `suggested_change_rel`;
    /// cost.json and identifiability.json state `schema_version`;
    /// changes.csv has typed columns (`change_rel`, `identified`); weak final
    /// pairs count as not reproduced, a refit that fits no better refutes the
    /// implication (issue 26).
    /// 17: dampers fitted from modes iterate to convergence and their
    /// damping ratios are judged (cause `damping`) (issue 26); the verdict's
    /// warnings are stage warnings (issue 29).
    /// 18: a refit of implicated parameters that fits only slightly better
    /// (less than 10 % lower RMS) is not taken (issue 26); eigenpairs of
    /// sparse models change in the last bits (the factor's ordering, issue
    /// 32).
    /// 19: `updated_model` refers to the input's super-element matrices
    /// (named with size and blake3 in its header) instead of copying them
    /// (issue 32).
    /// 20: a refit that fits materially better but needs a refitted value at
    /// a bound (outer 2.5 % of its range, or beyond `fixed_spread`) is no
    /// evidence for the screening: cause `screening_or_local_minimum`, the
    /// values judged in the verdict's `refit_values` (issue 26).
    /// 21: the FRF residuals' noise carries the modes' frequency drift
    /// (`frf_drift`, default 0): σ² = σ_c² + δ² s(ω)²; with FRFs, modal
    /// restarts that found nothing better and an escape search less thorough
    /// than the first FRF refinement are no evidence for model error
    /// (cause `not_searched` instead); with FRFs, updated_modes holds every
    /// model mode up to the top of their band (issue 26).
    /// 22: with FRFs, a fit within the noise overall is still above it
    /// when the worst window of 9 lines of one position is above 8σ
    /// (`LocalMisfit`, cost.json `verdict.frf.end.local`): a resonance the model
    /// misses or misplaces, which then gets the escape search and a cause;
    /// the intervals count FRF residuals correlated along frequency as
    /// fewer independent lines, (1 + ρ)/(1 − ρ) (issue 26).
    /// 23: with FRFs, each identified parameter's data variance is the
    /// larger of that and a leave-one-block-out (batch-means jackknife)
    /// sandwich over blocks of neighbouring lines across the channels of one
    /// reference at one position, on the t quantile of its effective number of blocks
    /// (`identify::batch_means`; identifiability.json `batch_lines`,
    /// `integrated_time_lines`; issue 26).
    /// 24: an implication of the score test that no refit tested, at a
    /// stalled fit, one that misplaces a resonance or one an escape search
    /// just reached, is cause
    /// `screening_or_local_minimum`, not `screened_out`; cost.json lists the
    /// follow-ups (`follow_ups`) and counts them in `phase_evaluations`; a
    /// refinement the subproblems left no budget for ends at the budget
    /// instead of failing the stage; a refit's refutation holds on the
    /// escape search's judgement (issue 26).
    /// 25: used by a reverted experiment (docs/uncertainty.md), skipped so
    /// that no cache holds its results under a current version.
    /// 26: an escape search that found nothing better is not assessed
    /// again (the same point; one assessment's evaluations fewer).
    /// 27: used by a reverted experiment (docs/uncertainty.md, step 1 in
    /// proportion to gradient cost), skipped.
    /// 28: a refit with plausible values that ends stalled or still
    /// misplacing a resonance names the screening and a local minimum as
    /// not told apart (was: the screening).
    /// 29: used by a reverted experiment (a uniqueness search), skipped.
    /// 30: with FRFs, the structural null directions come from the modal
    /// residuals and what the FRFs are a function of (each mode's
    /// denominator coefficients and residues), not from finite differences
    /// of the FRF residuals, whose error at a sharp peak made two guide
    /// shoes acting only through their sum look determined
    /// (`FrfReference::modal_observables`; issue 26).
    /// 31: a structural group whose sum is what the data determine (springs
    /// on one line of action) reports that sum with its standard errors and
    /// 95 % interval (`undetermined[].joint` of identifiability.json, the
    /// report; `identify::joint_effect`).
    /// 32: the FRF residuals' Jacobian columns of the analysis at the
    /// result come by the chain rule through the modal observables, not
    /// from central differences of the FRF residuals, which at peaks a few
    /// lines wide erred by up to 100 % (standard errors, consider intervals,
    /// the score test's sensitivities; `FrfReference::residual_columns`).
    /// 33: the modal continuation and the FRF refinement run
    /// Levenberg–Marquardt with a secant Jacobian (Broyden's update, one
    /// refreshed column per step) instead of a forward-difference Jacobian
    /// every step (`continuation.secant`, `frf_refinement.secant`); the
    /// verdict names model error only at a minimum (else
    /// `minimum_or_model_error`), and doubts the score test's parameters
    /// after a refit that needed values at their bounds wherever it ended.
    /// 34: no refit of the score test's parameters at an FRF fit within the
    /// noise below 1.04σ, which no refit can improve materially
    /// (`judging::NOISE_FLOOR_BOUND`); the normal equations of every
    /// least-squares step by one blocked product (`dense::normal_equations`;
    /// results differ from 33 in rounding).
    /// 35: an implication of the score test whose leading parameter's
    /// suggested change reaches its bound (outer 2.5 % of its range) is
    /// cause `screening_or_local_minimum`, not `screened_out`; the message
    /// says "to its bound", cost.json lists them (`implicated_at_bound`),
    /// identifiability.json marks them (`at_bound`).
    /// 36: every interval is checked against the cost at ±2σ along its
    /// parameter's conditional direction and widened by 1/√ρ where the cost
    /// is flatter than the Jacobian's quadratic, none where it does not rise
    /// (`identify::curvature`; identifiability.json `curvature`).
    /// 37: the records' truncation (`frf_truncated`) in partial fractions,
    /// one exponential per line instead of two per mode and line: the same
    /// FRFs to ~10⁻¹² relative, so such fits change at the rounding level.
    /// 38: a fit that needed a refitted value its bounds or spread hold is
    /// not ok even within the noise (cause `screening_or_local_minimum`);
    /// fits are unchanged, only such verdicts.
    /// 39: a window of the FRF fit far above the noise gets a warning
    /// naming the reference modes there and whether the modal fit used
    /// them (or that it has none); fits and verdicts are unchanged.
    /// 40: `shape_observability`: a mode seen by the sensors less than it
    /// (and at least `observability`) is compared by its frequency alone;
    /// unset (the default) fits are unchanged.
    /// 41: a window of the FRF fit far above the noise is searched first
    /// (the parameters acting on it over their box, then all identified
    /// ones; follow-up `window`): updates whose fit has such a window change.
    /// 42: the window's scan also places each model mode that crosses a
    /// window line between grid points on that line, and a refinement that
    /// mends the window but settles with another far above the noise has
    /// that one searched too, the first kept in the scan's misfit.
    /// 43: a warning names the identifiable parameters whose stated 95 %
    /// interval spans their whole box (fits unchanged).
    /// 44: a window search that gained materially and left a window far
    /// above the noise is followed by another where the budget left pays
    /// twice what it used (up to three in a row).
    fn version(&self) -> u32 {
        44
    }
    fn summary(&self) -> &'static str {
        "update model parameters so its modes match reference modes (black-box optimizer or sensitivity-guided subproblems and continuation), with identifiability and a verdict"
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    /// `subproblems` with `strategy: sensitivity_guided` only.
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("parameters", Artifact::Parameters),
        ("history", Artifact::History),
        ("updated_modes", Artifact::Modes),
        ("cost", Artifact::Cost),
        ("correlation", Artifact::Correlation),
        ("identifiability", Artifact::Identifiability),
        ("subproblems", Artifact::Json),
        ("updated_model", Artifact::Any),
    ];
    fn outputs(&self, p: &Checked) -> Vec<Output> {
        let guided = p.spec.guided();
        Self::OUTPUTS
            .iter()
            .filter(|(n, _)| guided || *n != "subproblems")
            .map(|(n, a)| Output::new(*n, *a))
            .collect()
    }
    fn uses_seed(&self) -> bool {
        true
    }
    fn seed(&self, p: &Checked) -> Option<u64> {
        p.params.seed
    }
    fn files(&self, p: &Checked) -> Vec<FileRef> {
        p.params
            .model
            .iter()
            .map(|m| FileRef {
                param: "model".into(),
                path: m.clone(),
                glob: false,
            })
            .collect()
    }
    fn file_dependencies(&self, p: &Checked, dir: &Path) -> Result<Vec<String>, ParamProblem> {
        let p = &p.params;
        let Some(path) = &p.model else {
            return Ok(Vec::new());
        };
        let (model, files) =
            super::params::model_files::checked_model_file(dir, path).map_err(|m| {
                problem(
                    &["model"],
                    m,
                    "paths are relative to the pipeline file; see pipelines/models/",
                )
            })?;
        let minimum = minimum_budget(model.parameters.len());
        if p.budget < minimum {
            return Err(problem(
                &["budget"],
                format!(
                    "budget {} cannot pay the assessment of the result over the model's {} \
                     parameters and a strategy",
                    p.budget,
                    model.parameters.len()
                ),
                &format!("give at least budget: {minimum} (2000 is the default)"),
            ));
        }
        Ok(files)
    }

    fn check_inputs(&self, p: &Checked, bound: &[&str]) -> Vec<ParamProblem> {
        let mut out = Vec::new();
        if p.spec.guided() && !bound.contains(&"sensitivity") {
            out.push(problem(
                &["strategy"],
                "strategy sensitivity_guided needs the `sensitivity` input",
                "bind a gsa stage's subproblems: `inputs: {sensitivity: gsa.subproblems}`",
            ));
        }
        if !bound.contains(&"model") && p.params.model.is_none() {
            out.push(problem(
                &[],
                "no model: bind the `model` input (a synthesize `model` output) or give the `model` param",
                "",
            ));
        }
        out
    }

    fn run(&self, p: &Checked, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let started = Instant::now();
        let spec = &p.spec;
        let model = load_model(ctx, p.params.model.as_deref())?;
        let mut objective = inputs::modal_objective(ctx, &model, spec)?;
        ctx.progress.set_length(spec.budget as u64);
        let progress = |n: u64| ctx.progress.inc(n);
        let screening_input = if spec.guided() {
            Some(inputs::screening(ctx)?)
        } else {
            None
        };
        let default_slsqp = SlsqpParams::default();
        let strategy = strategy(spec, screening_input.as_ref(), &default_slsqp);
        let frf_reference = inputs::frf_reference(ctx, &objective, spec)?;
        let plan = Plan {
            frf: frf_reference.as_ref().map(|r| (r, &spec.frf_refinement)),
            strategy,
            budget: spec.budget,
            seed: ctx.seed,
            observability: spec.observability,
            exclude: &spec.exclude,
            max_std_error: spec.max_std_error,
            fixed_spread: spec.fixed_spread,
            refit_implicated: spec.refit_implicated,
        };
        let mut u = update(&mut objective, &plan, &progress).map_err(update_error)?;
        if let Some(w) = frf_reference.as_ref().and_then(|r| r.noise_warning()) {
            u.verdict.warnings.push(w);
        }
        if !u.verdict.ok {
            ctx.progress
                .set_message(format!("verdict: {}", u.verdict.message));
        }
        let top_hz = frf_reference.as_ref().map(|r| r.top_hz());
        let mut files = write_outputs(ctx, &objective, spec, &u, top_hz, started)?;
        // The updated model file (see stages::updated_model).
        let model_dir = ctx.scratch.join("updated_model");
        let parameters = ctx.scratch.join("parameters.csv");
        updated_model::write(ctx, p.params.model.as_deref(), &parameters, &model_dir)?;
        files.push(("updated_model".to_string(), model_dir));
        Ok(StageOutputs {
            // The verdict's warnings are the stage's too: `warning:` lines,
            // the run's count and every report below, cached or not.
            warnings: u.verdict.warnings.clone(),
            files,
            counters: [("evaluations".to_string(), u.evaluations as u64)].into(),
        })
    }
}

/// The strategy the spec names: guided over the `screening` (its
/// subproblems solved by the spec's SLSQP, `default_slsqp` only if the spec
/// holds another optimizer, which [`spec::spec`] refuses for guided), or
/// the spec's optimizer over all parameters.
fn strategy<'a>(
    spec: &'a Spec,
    screening: Option<&'a ScreeningInput>,
    default_slsqp: &'a SlsqpParams,
) -> Strategy<'a> {
    let slsqp = match &spec.optimizer {
        Optimizer::Slsqp(p) => p,
        _ => default_slsqp,
    };
    match screening {
        Some(s) => Strategy::Guided {
            screening: Screening {
                specs: &s.specs,
                significant: s.significant.as_deref(),
                modes: &s.modes,
            },
            settings: &spec.settings,
            slsqp,
        },
        None => Strategy::BlackBox {
            optimizer: &spec.optimizer,
        },
    }
}

/// The stage error of a failed update: whose fault it is.
fn update_error(e: IdentifyError) -> StageError {
    match e {
        // A budget the model or the screening make too small (a model
        // from the `model` input is first seen here): the param's fault.
        IdentifyError::Invalid(m) if m.starts_with("budget ") => StageError::InvalidParam {
            param: "budget".into(),
            message: m,
        },
        IdentifyError::Invalid(m) => StageError::InvalidInput {
            input: "reference".into(),
            message: m,
        },
        e => StageError::Failed(e.to_string()),
    }
}

/// The fewest evaluations an identification over `n` parameters can run
/// with: the assessment of the result without the intervals' check
/// ([`crate::identify::updating::assessment_reserve`]), the result's J and
/// one for a strategy.
fn minimum_budget(n: usize) -> usize {
    crate::identify::updating::assessment_reserve(n, 0) + 2
}

/// Write every output into the scratch directory.
fn write_outputs(
    ctx: &StageContext,
    o: &ModalObjective,
    spec: &Spec,
    u: &Update,
    top_hz: Option<f64>,
    started: Instant,
) -> Result<Vec<(String, std::path::PathBuf)>, StageError> {
    let failed = |e: IdentifyError| StageError::Failed(e.to_string());
    let mut files = Vec::new();
    let mut add = |name: &str, file: &str| {
        let path = ctx.scratch.join(file);
        files.push((name.to_string(), path.clone()));
        path
    };
    crate::artifacts::parameters::write(
        &add("parameters", crate::artifacts::parameters::FILE),
        &outputs::parameter_rows(o, u),
    )?;
    crate::artifacts::history::write(
        &add("history", crate::artifacts::history::FILE),
        &outputs::history_rows(u),
    )?;
    crate::artifacts::correlation::write(
        &add("correlation", crate::artifacts::correlation::FILE),
        &outputs::correlation_rows(o, u),
    )?;
    outputs::identifiability(u).write(&add(
        "identifiability",
        crate::artifacts::identifiability::FILE,
    ))?;
    let mut put = |name: &str, file: &str, text: String| -> Result<(), StageError> {
        let path = ctx.scratch.join(file);
        write(&path, &text)?;
        files.push((name.to_string(), path));
        Ok(())
    };
    let mut phases = Phases {
        assessment: u.assessment_evaluations,
        frf: u.frf_evaluations,
        optimizer: u.optimizer.as_ref().map_or(0, |r| r.evaluations),
        follow_ups: u.follow_ups.iter().map(|f| f.evaluations).sum(),
        ..Phases::default()
    };
    if let Some(g) = &u.guided {
        [phases.subproblems, phases.refine, phases.damping] = g.phase_evaluations;
        let names = |idx: &[usize]| -> Vec<String> {
            idx.iter()
                .map(|&i| o.parameters()[i].name.clone())
                .collect()
        };
        let json = serde_json::json!({
            "settings": spec.settings,
            "subproblems": g.subproblems,
            "skipped": g.skipped.iter().map(|(o, why)| serde_json::json!({"output": o, "reason": why})).collect::<Vec<_>>(),
            "chosen": g.chosen,
            "refinement": g.refinement,
            "stiffness_parameters": names(&g.stiffness),
            "damping_parameters": names(&g.damping),
            "damping_equations": g.damping_equations,
            "damping_rms_residual": g.damping_rms_residual,
        });
        put(
            "subproblems",
            "subproblems.json",
            serde_json::to_string_pretty(&json).unwrap_or_default() + "\n",
        )?;
    }
    let updated = ctx.scratch.join(artifacts::modes::DIR);
    // With FRFs, every model mode in their band: the update's prediction of
    // the modes the reference modes lack.
    let modes = match top_hz {
        Some(top) => o.model_modes_through(&u.x, top),
        None => o.model_modes(&u.x),
    };
    artifacts::modes::write_modes(&updated, &modes.map_err(failed)?)?;
    files.push(("updated_modes".to_string(), updated));
    let cost = Cost {
        schema_version: Default::default(),
        evaluations: u.evaluations,
        seconds: started.elapsed().as_secs_f64(),
        best_objective: u.objective,
        strategy: spec.strategy.as_str().into(),
        // Guided: always slsqp, the only optimizer `spec` allows it.
        optimizer: spec.optimizer.name().to_string(),
        modes: o.summary(&u.x).map_err(failed)?,
        phase_evaluations: phases,
        frf: u.frf.as_ref().map(|r| r.summary.clone()),
        follow_ups: u.follow_ups.clone(),
        verdict: u.verdict.clone(),
    };
    let path = ctx.scratch.join(crate::artifacts::cost::FILE);
    cost.write(&path)?;
    files.push(("cost".to_string(), path));
    Ok(files)
}
