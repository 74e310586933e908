//! The settings of the identification the `identify` params make
//! ([`Spec`]); [`spec`] checks what the types cannot say, every problem
//! located by its param path. [`Checked`] derives the Spec once, when the
//! params are parsed at validation, and the run uses that one.

use super::params::{
    problem, Params, StrategyName, GUIDED_OPTIMIZER, PAIRING_MIN_MAC, PAIRING_WINDOW,
};
use crate::identify::frf_refinement::FrfRefinementParams;
use crate::identify::{GuidedParams, Observability, Uncertainty, Weights};
use crate::optimize::Optimizer;
use crate::pairing::Pairing;
use crate::stages::{Field, ParamProblem, ParamSet};
use serde_yaml_ng::Mapping;

/// The `identify` kind's params as the engine holds them
/// ([`crate::stages::Kind::Params`]): the params as declared and the
/// identification they describe, derived once when they are parsed ("parse
/// once, then types"), so validation and the run share one [`Spec`].
pub struct Checked {
    pub params: Params,
    pub spec: Spec,
}

impl ParamSet for Checked {
    /// The declared params, then the [`Spec`] they describe: every problem
    /// of either, as the kind's checks report them.
    fn parse(params: &Mapping) -> Result<Self, Vec<ParamProblem>> {
        let params = Params::parse(params)?;
        let spec = spec(&params)?;
        Ok(Checked { params, spec })
    }
    fn fields() -> Vec<Field> {
        Params::fields()
    }
}

/// The identification the params describe.
pub struct Spec {
    pub strategy: StrategyName,
    pub optimizer: Optimizer,
    pub budget: usize,
    pub settings: GuidedParams,
    pub weights: Weights,
    pub pairing: Pairing,
    pub uncertainty: Uncertainty,
    pub observability: Observability,
    pub max_std_error: f64,
    /// σ of ln p of every fixed parameter (`None`: from its bounds).
    pub fixed_spread: Option<f64>,
    pub refit_implicated: bool,
    pub positions: Option<Vec<u32>>,
    pub frf_refinement: FrfRefinementParams,
    pub frf_band: (f64, f64),
    pub frf_averages: Option<usize>,
    pub frf_drift: f64,
    /// `Some(t₀)`: impact-test records truncated, the hit t₀ into them.
    pub frf_truncation: Option<f64>,
    /// Nominal-model modes to leave out: (position, number).
    pub exclude: Vec<(u32, usize)>,
}

impl Spec {
    /// Whether the strategy is sensitivity_guided (GSA subproblems,
    /// continuation, damping fit) rather than one black-box optimizer.
    pub fn guided(&self) -> bool {
        self.strategy == StrategyName::SensitivityGuided
    }
}

/// The settings of the identification, or every problem with them.
pub fn spec(p: &Params) -> Result<Spec, Vec<ParamProblem>> {
    let mut out = Vec::new();
    let optimizer = optimizer(p, &mut out);
    let settings = guided_settings(p, &mut out);
    check_weights(p.weights, &mut out);
    let pairing = pairing(p, &mut out);
    check_reference_modes(p, &mut out);
    let frf_band = frf_settings(p, &mut out);
    match optimizer {
        Some(optimizer) if out.is_empty() => Ok(Spec {
            strategy: p.strategy,
            optimizer,
            budget: p.budget,
            settings,
            weights: p.weights,
            pairing,
            uncertainty: p.uncertainty,
            observability: Observability {
                modes: p.observability,
                shapes: p.shape_observability.unwrap_or(p.observability),
            },
            max_std_error: p.max_std_error,
            // A relative σ r is σ of ln p ≈ ln(1 + r).
            fixed_spread: p.fixed_spread.map(f64::ln_1p),
            refit_implicated: p.refit_implicated,
            positions: p.positions.clone(),
            frf_refinement: p.frf_refinement.clone(),
            frf_band,
            frf_averages: p.frf_averages,
            frf_drift: p.frf_drift,
            frf_truncation: p.frf_truncated.then_some(p.frf_pre_trigger_s),
            exclude: p
                .exclude_modes
                .iter()
                .map(|m| (m.position, m.mode))
                .collect(),
        }),
        _ => Err(out),
    }
}

/// The optimizer `optimizer` and `optimizer_settings` name, `None` when its
/// settings are wrong; a guided strategy allows only its own optimizer.
fn optimizer(p: &Params, out: &mut Vec<ParamProblem>) -> Option<Optimizer> {
    if p.strategy == StrategyName::SensitivityGuided && p.optimizer != GUIDED_OPTIMIZER {
        out.push(problem(
            &["optimizer"],
            format!(
                "sensitivity_guided uses {} per subproblem, not {}",
                GUIDED_OPTIMIZER.as_str(),
                p.optimizer.as_str()
            ),
            "remove `optimizer` or use strategy: black_box",
        ));
    }
    p.optimizer
        .optimizer(p.optimizer_settings.as_ref())
        .map_err(|e| {
            out.push(problem(
                &["optimizer_settings"],
                e.to_string(),
                "see the optimizer's settings in docs/stage-kinds.md (`identify`)",
            ))
        })
        .ok()
}

/// The sensitivity-guided settings, `repeats` (the short form) merged into
/// `guided`, checked.
fn guided_settings(p: &Params, out: &mut Vec<ParamProblem>) -> GuidedParams {
    let mut settings = p.guided.value.clone();
    if let Some(r) = p.repeats {
        if p.guided.has("repeats") {
            out.push(problem(
                &["guided", "repeats"],
                "`repeats` is given twice",
                "give it once, as `repeats` or as `guided.repeats`",
            ));
        }
        settings.repeats = r;
    }
    if let Err(m) = settings.check() {
        out.push(problem(
            &["guided"],
            m,
            "see the guided settings in docs/stage-kinds.md (`identify`)",
        ));
    }
    settings
}

/// Check the criteria weights {mac, nfd, ndd}: each non-negative, not all 0.
fn check_weights(w: Weights, out: &mut Vec<ParamProblem>) {
    for (k, x) in [("mac", w.mac), ("nfd", w.nfd), ("ndd", w.ndd)] {
        if !(x >= 0.0 && x.is_finite()) {
            out.push(problem(
                &["weights", k],
                format!("weight {k} = {x} must be ≥ 0"),
                "weights are non-negative",
            ));
        }
    }
    if w.mac + w.nfd + w.ndd == 0.0 {
        out.push(problem(
            &["weights"],
            "all weights are 0",
            "give at least one positive weight",
        ));
    }
}

/// The mode pairing: `pairing` with identification's own defaults for what
/// it leaves out and `window` (the short form) merged in, checked.
fn pairing(p: &Params, out: &mut Vec<ParamProblem>) -> Pairing {
    // Identification's own defaults: a model 30 % off moves modes by up to
    // 20 %, and a pair below MAC 0.5 is no evidence of one physical mode.
    let mut pairing = p.pairing.value;
    if !p.pairing.has("window") {
        pairing.window = PAIRING_WINDOW;
    }
    if !p.pairing.has("min_mac") {
        pairing.min_mac = PAIRING_MIN_MAC;
    }
    if let Some(w) = p.window {
        if p.pairing.has("window") {
            out.push(problem(
                &["window"],
                "the pairing window is given twice",
                "give it once, as `window` or as `pairing.window`",
            ));
        }
        pairing.window = w;
    }
    if let Err(m) = pairing.check() {
        out.push(problem(
            &["pairing"],
            m,
            "e.g. pairing: {window: 0.2, frequency_scale: 0.1}",
        ));
    }
    pairing
}

/// Check what the params say of the reference modes: their uncertainty and
/// the positions used.
fn check_reference_modes(p: &Params, out: &mut Vec<ParamProblem>) {
    if let Err(m) = p.uncertainty.check() {
        out.push(problem(
            &["uncertainty"],
            m,
            "standard deviations are positive",
        ));
    }
    if p.positions.as_ref().is_some_and(Vec::is_empty) {
        out.push(problem(
            &["positions"],
            "`positions` must be a non-empty list of position indices",
            "e.g. positions: [0, 2]",
        ));
    }
}

/// The band [low, high] Hz of the FRF lines fitted (default: all), after
/// checking it and the FRF refinement's settings.
fn frf_settings(p: &Params, out: &mut Vec<ParamProblem>) -> (f64, f64) {
    if let Err(m) = p.frf_refinement.check() {
        out.push(problem(
            &["frf_refinement"],
            m,
            "see the FRF refinement in docs/stage-kinds.md (`identify`)",
        ));
    }
    if p.frf_pre_trigger_s > 0.0 && !p.frf_truncated {
        out.push(problem(
            &["frf_pre_trigger_s"],
            "places the hit for the record's truncation, which is off",
            "add `frf_truncated: true` (impact tests without an exponential window), or drop `frf_pre_trigger_s`",
        ));
    }
    let frf_band = p.frf_band.unwrap_or((0.0, f64::INFINITY));
    if frf_band.0 >= frf_band.1 {
        out.push(problem(
            &["frf_band"],
            format!(
                "frf_band [{}, {}] is not [low, high]",
                frf_band.0, frf_band.1
            ),
            "e.g. frf_band: [10, 200]",
        ));
    }
    frf_band
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observability(yaml: &str) -> Observability {
        let map: Mapping = serde_yaml_ng::from_str(yaml).unwrap();
        Checked::parse(&map).ok().unwrap().spec.observability
    }

    /// Unset, `shape_observability` follows `observability`, so no mode is
    /// compared by its frequency alone (identify 39's fits); given, it sets
    /// the upper threshold on its own.
    #[test]
    fn shape_observability_defaults_to_observability() {
        let at = |modes, shapes| Observability { modes, shapes };
        assert_eq!(observability("{model: m.yaml}"), at(0.25, 0.25));
        assert_eq!(
            observability("{model: m.yaml, observability: 0.05}"),
            at(0.05, 0.05)
        );
        assert_eq!(
            observability("{model: m.yaml, observability: 0.05, shape_observability: 0.25}"),
            at(0.05, 0.25)
        );
    }
}
