//! AutoEMA end to end (seed section 5.2.2, PUB5): PolyMAX poles once up to
//! the highest order, then Bayesian optimization on a fixed Sobol design
//! ([`super::design`]) of the selection hyperparameters over a box fitted
//! to the data ([`super::hyperbox`]), maximizing J(θ) of
//! [`super::selection`]. The result is a function of the data: there is no
//! seed. The budget `evaluations` is extended (up to 3×) until the kept
//! result has stood for a quarter of it ([`settled`]).
//!
//! Among the evaluated points whose score is within max(10⁻⁶, 1 % of
//! 1 − J*) of the best J* and that have as many modes, the one farthest from
//! the box's faces (in the searched, partly logarithmic, coordinates) is
//! kept, so a flat optimum does not end at a bound by chance. Its modes are
//! checked against the selections of the next-best points ([`consensus`]).
//! A result still at a bound is probed beyond it
//! ([`super::hyperbox::AtBound`]). The final
//! fit is checked against the noise floor ([`super::residual`]); both go to
//! the result's warnings.

use super::design::SobolSearch;
use super::hyperbox::{box_warning, AtBound, DataSummary, LOG_SCALE};
use super::lsfd::LsfdFit;
use super::peak_evidence::unresolved_pairs;
use super::polymax::{polymax, PoleOrder, PolymaxParams};
use super::residual::{self, missing_mode_warnings, ResidualPeak};
use super::selection::{
    final_fit, refine_selection, select_modes, Hyperparameters, Screening, Selection,
    SelectionParams, HYPERPARAMETER_NAMES,
};
use super::{adequacy, whitening, EmaError, FrfData};
use std::collections::BTreeMap;

mod bounds;
mod consensus;
use bounds::{probe_bounds, settle};
use consensus::consensus;
pub use consensus::{CONSENSUS_MAX_SCORE, CONSENSUS_MIN_LINES};

/// Settings of [`auto_ema`].
#[derive(Clone, Debug, PartialEq)]
pub struct AutoEmaParams {
    /// Range of the maximum model order; `None`: fitted to the data
    /// ([`DataSummary::max_order_range`]).
    pub max_order: Option<(usize, usize)>,
    /// Objective evaluations of the Bayesian optimization (initial design
    /// included), at least: the search goes on, up to three times as many,
    /// until its result has stood for a quarter of them ([`settled`]).
    pub evaluations: usize,
    /// Sobol design points before the surrogate takes over.
    pub initial: usize,
    pub selection: SelectionParams,
    /// Variant of the Sobol design ([`super::design::SobolSearch::new`]):
    /// 0, the method's design, in the stage; others only to study how much
    /// a result owes to the design.
    pub design: u32,
    /// Hyperparameters pinned to a value (names of [`HYPERPARAMETER_NAMES`]).
    pub fixed: BTreeMap<String, f64>,
    /// Search ranges replacing the fitted ones.
    pub bounds: BTreeMap<String, (f64, f64)>,
    /// The noise model along the band ([`whitening::NoiseModel`]).
    pub noise: whitening::NoiseModel,
    /// Next-best selections of the search each mode is checked against
    /// ([`consensus`]); 0: none.
    pub consensus: usize,
}

impl Default for AutoEmaParams {
    fn default() -> Self {
        AutoEmaParams {
            max_order: None,
            evaluations: 40,
            initial: 12,
            selection: SelectionParams::default(),
            design: 0,
            fixed: BTreeMap::new(),
            bounds: BTreeMap::new(),
            noise: whitening::NoiseModel::Auto,
            consensus: 12,
        }
    }
}

/// One optimization step.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TraceEntry {
    pub hyperparameters: Hyperparameters,
    pub mean_frac: f64,
    pub n_modes: usize,
    pub n_rejected: usize,
    pub objective: f64,
}

/// Poles of all orders, the chosen selection, its final fit and what the
/// search and the checks found.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoEmaResult {
    pub orders: Vec<PoleOrder>,
    pub best: Selection,
    /// Per root of `best`: how many of the `consensus_of` next-best
    /// selections of the search hold it ([`consensus`]).
    pub support: Vec<usize>,
    /// Per root of `best`: the variance inflation of its ΔRSS by the serial
    /// correlation of the residual ([`super::serial_correlation`]).
    pub serial_inflation: Vec<f64>,
    pub consensus_of: usize,
    pub fit: LsfdFit,
    pub trace: Vec<TraceEntry>,
    pub summary: DataSummary,
    /// The search box, per hyperparameter (fixed ones as a point).
    pub bounds: [(f64, f64); 9],
    pub at_bound: Vec<AtBound>,
    /// Lines where the final fit leaves structure above the noise.
    pub residual_peaks: Vec<ResidualPeak>,
    /// Relative error ε at the resonances: the larger of the data's
    /// ([`super::noise::relative_noise`]) and the fit's misfit
    /// ([`super::residual::relative_misfit`]), as an amplitude ratio.
    pub relative_error: f64,
    /// CMIF curves (singular values per line).
    pub cmif: Vec<Vec<f64>>,
    /// Noise variance per channel (whitened data: at the lines of median
    /// weight, u = 1).
    pub noise: Vec<f64>,
    /// Everything a user must know, as sentences.
    pub warnings: Vec<String>,
}

impl AutoEmaResult {
    /// Whether the analysis reached its goal: none of its warnings stands
    /// (a visible mode missed, a result limited by the box, references that
    /// do not share their poles); each asks the user to act.
    pub fn goal_reached(&self) -> bool {
        self.warnings.is_empty()
    }
}

fn invalid(name: &str, message: String) -> EmaError {
    EmaError::InvalidParam {
        name: name.into(),
        message,
    }
}

fn index_of(name: &str, what: &str) -> Result<usize, EmaError> {
    HYPERPARAMETER_NAMES
        .iter()
        .position(|n| *n == name)
        .ok_or_else(|| {
            invalid(
                &format!("{what}.{name}"),
                format!(
                    "unknown hyperparameter; known: {}",
                    HYPERPARAMETER_NAMES.join(", ")
                ),
            )
        })
}

/// The search box and the pinned values, per hyperparameter.
type Space = ([(f64, f64); 9], [Option<f64>; 9]);

/// The box and the pinned values.
fn search_space(p: &AutoEmaParams, summary: &DataSummary) -> Result<Space, EmaError> {
    let range = p.max_order.unwrap_or_else(|| summary.max_order_range());
    if range.0 == 0 || range.0 > range.1 {
        return Err(invalid(
            "max_order",
            format!("range [{}, {}] is empty or starts at 0", range.0, range.1),
        ));
    }
    let mut bounds = summary.bounds(range);
    for (name, &(lo, hi)) in &p.bounds {
        let k = index_of(name, "bounds")?;
        if !(lo.is_finite()
            && hi.is_finite()
            && lo <= hi
            && (lo > 0.0 || !LOG_SCALE[k])
            && lo >= 0.0)
        {
            return Err(invalid(&format!("bounds.{name}"), format!("[{lo}, {hi}] is not a range of non-negative numbers (positive for a log-scale tolerance)")));
        }
        if k == 8 {
            return Err(invalid(
                "bounds.max_order",
                "give the order range as `max_order: [min, max]`".into(),
            ));
        }
        bounds[k] = (lo, hi);
    }
    let mut fixed = [None; 9];
    for (k, v) in summary.implied() {
        fixed[k] = Some(v);
    }
    for (name, &v) in &p.fixed {
        let k = index_of(name, "fixed")?;
        if !v.is_finite() || v < 0.0 {
            return Err(invalid(
                &format!("fixed.{name}"),
                format!("{v} must be finite and non-negative"),
            ));
        }
        fixed[k] = Some(v);
    }
    if range.0 == range.1 && fixed[8].is_none() {
        fixed[8] = Some(range.0 as f64);
    }
    for k in 0..9 {
        if let Some(v) = fixed[k] {
            bounds[k] = (v, v);
        }
    }
    Ok((bounds, fixed))
}

/// The free hyperparameters and how the search's coordinates map to them:
/// the pinned values stay, the free ones are searched on their box, in
/// logarithmic coordinates where [`LOG_SCALE`] says so.
struct Coordinates {
    /// Pinned value per hyperparameter (`None`: searched).
    fixed: [Option<f64>; 9],
    /// Indices of the searched hyperparameters.
    free: Vec<usize>,
    /// Search range of each free hyperparameter, in search coordinates.
    search: Vec<(f64, f64)>,
}

impl Coordinates {
    /// The searched coordinates of the box `bounds` with the values `fixed`
    /// pinned.
    fn new(bounds: &[(f64, f64); 9], fixed: [Option<f64>; 9]) -> Coordinates {
        let free: Vec<usize> = (0..9).filter(|&k| fixed[k].is_none()).collect();
        let to_search = |k: usize, v: f64| if LOG_SCALE[k] { v.ln() } else { v };
        let search: Vec<(f64, f64)> = free
            .iter()
            .map(|&k| (to_search(k, bounds[k].0), to_search(k, bounds[k].1)))
            .collect();
        Coordinates {
            fixed,
            free,
            search,
        }
    }

    /// The hyperparameter point of the search coordinates `x`.
    fn point(&self, x: &[f64]) -> Hyperparameters {
        let mut a = self.fixed.map(|v| v.unwrap_or(0.0));
        for (&k, &v) in self.free.iter().zip(x) {
            a[k] = if LOG_SCALE[k] { v.exp() } else { v };
        }
        Hyperparameters::from_array(a)
    }
}

/// Every evaluation of the search: its trace entry and its coordinates.
struct Evaluations {
    trace: Vec<TraceEntry>,
    xs: Vec<Vec<f64>>,
}

/// Bayesian optimization of J(θ) on the Sobol design over the free
/// coordinates (a single evaluation when none is free), extended until
/// [`settled`]; returns every evaluation, for [`choose`].
fn search_hyperparameters(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    coordinates: &Coordinates,
    p: &AutoEmaParams,
    on_step: &(dyn Fn() + Sync),
) -> Evaluations {
    let mut trace = Vec::new();
    let mut xs: Vec<Vec<f64>> = Vec::new();
    let mut objective = |x: &[f64]| {
        let h = coordinates.point(x);
        let s = select_modes(screening, orders, &h);
        trace.push(TraceEntry {
            hyperparameters: h,
            mean_frac: s.mean_frac,
            n_modes: s.n_modes(),
            n_rejected: s.rejected.len(),
            objective: s.objective,
        });
        xs.push(x.to_vec());
        on_step();
        (s.objective, s.n_modes())
    };
    if coordinates.free.is_empty() {
        objective(&[]);
    } else {
        let budget = p.evaluations.max(1);
        let mut bo = SobolSearch::new(coordinates.free.len(), p.initial.clamp(1, budget), p.design);
        // (objective, modes) of every evaluation.
        let mut values: Vec<(f64, usize)> = Vec::new();
        loop {
            let u = bo.ask();
            let x: Vec<f64> = u
                .iter()
                .zip(&coordinates.search)
                .map(|(v, &(lo, hi))| lo + v.clamp(0.0, 1.0) * (hi - lo))
                .collect();
            let (y, n_modes) = objective(&x);
            bo.tell(u, y);
            values.push((y, n_modes));
            if settled(&values, budget) {
                break;
            }
        }
    }
    Evaluations { trace, xs }
}

/// (frequency, damping ratio) of every root of `best`.
fn identified_modes(orders: &[PoleOrder], best: &Selection) -> Vec<(f64, f64)> {
    best.roots
        .iter()
        .map(|r| {
            let p = r.pole(orders);
            (p.frequency_hz, p.damping_ratio)
        })
        .collect()
}

/// The final fit's check against the noise floor ([`residual::check`]).
fn check_fit(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    best: &Selection,
    fit: &LsfdFit,
) -> (f64, Vec<ResidualPeak>) {
    residual::check(
        screening.data,
        &screening.noise,
        &fit.reconstructed,
        &identified_modes(orders, best),
    )
}

/// The sentences that ask the user to act.
fn warnings(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    best: &Selection,
    at_bound: &[AtBound],
    residual_peaks: &[ResidualPeak],
) -> Vec<String> {
    // Warnings ask the user to act: modes that depend on the box, a mode the
    // data show and the fit misses, a fit the noise does not explain. Bounds
    // and residual structure that do not matter stay in metrics.json only.
    let mut warnings: Vec<String> = box_warning(at_bound).into_iter().collect();
    let modes = identified_modes(orders, best);
    warnings.extend(missing_mode_warnings(residual_peaks, &modes));
    warnings.extend(inconsistent_references(screening, orders, best));
    let (data, noise) = (screening.data, &screening.noise);
    warnings.extend(adequacy::check(data, noise, best.mean_frac, &modes));
    warnings
}

/// PolyMAX up to the highest order, then Bayesian optimization of the
/// selection hyperparameters; `on_step` is called after every evaluation.
pub fn auto_ema(
    raw: &FrfData,
    p: &AutoEmaParams,
    on_step: &(dyn Fn() + Sync),
) -> Result<AutoEmaResult, EmaError> {
    if !(p.selection.alpha > 0.0 && p.selection.alpha < 1.0) {
        return Err(invalid(
            "significance",
            format!("α = {} must lie in (0, 1)", p.selection.alpha),
        ));
    }
    // Noise that varies along the band is whitened ([`super::whitening`]):
    // the analysis works on the whitened data and reports in the units of
    // `raw`. Where the weights leave PolyMAX's normal equations singular
    // at the top order, the data are analysed as given (white noise), with
    // a warning.
    match p.noise.whitened(raw) {
        Some(white) => match analyse(raw, &white, p, on_step) {
            Err(EmaError::IllConditioned { order }) => {
                let mut r = analyse(raw, raw, p, on_step)?;
                r.warnings.push(format!(
                    "the noise varies {:.0}× along the band, but weighted by it PolyMAX's normal equations are singular at order {order}; the FRFs were analysed with white noise, which hides weak modes where the noise is low: narrow `band`, or set `noise: white` to accept this",
                    whitening::range(&white.line_weight)
                ));
                Ok(r)
            }
            r => r,
        },
        None => analyse(raw, raw, p, on_step),
    }
}

/// [`auto_ema`] on `data`, `raw` itself or whitened.
fn analyse(
    raw: &FrfData,
    data: &FrfData,
    p: &AutoEmaParams,
    on_step: &(dyn Fn() + Sync),
) -> Result<AutoEmaResult, EmaError> {
    let mut screening = Screening::new(data, p.selection.clone());
    let mut summary = DataSummary::of(data, &screening.cmif, &screening.noise);
    summary.noise_profile_range = data
        .is_whitened()
        .then(|| whitening::range(&data.line_weight));
    let (bounds, fixed) = search_space(p, &summary)?;
    let top_order = bounds[8].1.round().max(1.0) as usize;
    let orders = polymax(
        data,
        &PolymaxParams {
            max_order: top_order,
        },
    )?;
    let coordinates = Coordinates::new(&bounds, fixed);
    let Evaluations { trace, xs } =
        search_hyperparameters(&mut screening, &orders, &coordinates, p, on_step);
    let chosen = choose(&trace, &xs, &coordinates.search);
    let best = select_modes(&mut screening, &orders, &coordinates.point(&xs[chosen]));
    let probes = probe_bounds(
        &mut screening,
        &orders,
        &best,
        &xs[chosen],
        &coordinates.search,
        &coordinates.free,
        &|x| coordinates.point(x),
    );
    let refined = refine_selection(&mut screening, &orders, &best);
    let objectives: Vec<f64> = trace.iter().map(|t| t.objective).collect();
    let checked = consensus(
        &mut screening,
        &orders,
        &objectives,
        &xs,
        chosen,
        p.consensus,
        &|x| coordinates.point(x),
        refined,
        summary.line_spacing_hz,
    );
    let mut best = checked.selection;
    let at_bound = settle(probes, &mut screening, &orders, &best);
    let mut fit = final_fit(data, &orders, &best)?;
    let (relative_error, residual_peaks) = check_fit(&screening, &orders, &best, &fit);
    if data.is_whitened() {
        // σ_k(u·H) = u·σ_k(H) line by line: the reconstruction of the FRFs
        // as given and its FRAC, and below their CMIF.
        data.unwhiten(&mut fit.reconstructed);
        best.mean_frac = fit.mean_frac(raw);
    }
    let warnings = warnings(&screening, &orders, &best, &at_bound, &residual_peaks);
    let mut cmif = screening.cmif;
    if data.is_whitened() {
        cmif.iter_mut().for_each(|curve| data.unwhiten_lines(curve));
    }
    Ok(AutoEmaResult {
        orders,
        best,
        support: checked.support,
        serial_inflation: checked.inflation,
        consensus_of: checked.of,
        fit,
        trace,
        summary,
        bounds,
        at_bound,
        residual_peaks,
        relative_error: relative_error.sqrt(),
        cmif,
        noise: screening.noise,
        warnings,
    })
}

/// Pairs of modes that close together on a single CMIF peak (see
/// [`unresolved_pairs`]) from which the references are called inconsistent.
const INCONSISTENT_PAIRS: usize = 3;

/// The warning that the references do not share their poles, when
/// [`INCONSISTENT_PAIRS`] or more modes appear twice within 1.5 lines.
fn inconsistent_references(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    best: &Selection,
) -> Option<String> {
    let f: Vec<f64> = best
        .roots
        .iter()
        .map(|r| r.pole(orders).frequency_hz)
        .collect();
    let pairs = unresolved_pairs(screening.evidence.step_hz, &f);
    (pairs.len() >= INCONSISTENT_PAIRS).then(|| {
        let list: Vec<String> = pairs
            .iter()
            .map(|(a, b)| format!("{a:.2}/{b:.2}"))
            .collect();
        format!(
            "{} modes appear twice within 1.5 line spacings ({} Hz), each kept because another reference sees its own version: the references do not share their poles (measured in different set-ups, moving mass loading, or a structure that changed during the test); analyse each reference column on its own, or check the test",
            pairs.len(),
            list.join(", ")
        )
    })
}

/// Evaluations the best result must have stood before the search stops,
/// and the budget multiple at which it stops regardless.
const PATIENCE_FRACTION: f64 = 0.25;
const MAX_BUDGET_FACTOR: usize = 3;

/// Whether the search may stop after the evaluations `values` (objective,
/// modes): the budget is spent and the result [`choose`] would keep (the
/// best objective up to max(10⁻⁶, 1 % of 1 − J*), with its number of
/// modes) was first reached at least max(4, ¼ budget) evaluations ago —
/// or three budgets are spent. A result still changing when the budget
/// ends is the one a different design would have missed.
fn settled(values: &[(f64, usize)], budget: usize) -> bool {
    let n = values.len();
    if n < budget {
        return false;
    }
    if n >= MAX_BUDGET_FACTOR * budget {
        return true;
    }
    let Some(best) = (0..n).max_by(|&a, &b| values[a].0.total_cmp(&values[b].0).then(b.cmp(&a)))
    else {
        return true;
    };
    let (j, modes) = values[best];
    let tol = (0.01 * (1.0 - j)).max(1e-6);
    let first = (0..n)
        .find(|&k| values[k].0 >= j - tol && values[k].1 == modes)
        .unwrap_or(best);
    let patience = ((PATIENCE_FRACTION * budget as f64).ceil() as usize).max(4);
    n - 1 - first >= patience
}

/// Smallest distance to a face of the box in unit coordinates.
fn centrality(x: &[f64], search: &[(f64, f64)]) -> f64 {
    x.iter()
        .zip(search)
        .map(|(&v, &(lo, hi))| {
            if hi > lo {
                ((v - lo) / (hi - lo)).min((hi - v) / (hi - lo))
            } else {
                0.5
            }
        })
        .fold(0.5, f64::min)
}

/// How far below the best objective `j` another evaluation still ties with
/// it: 1 % of the misfit 1 − J*, at least 10⁻⁶.
fn tie_tolerance(j: f64) -> f64 {
    (0.01 * (1.0 - j)).max(1e-6)
}

/// Index of the kept evaluation: the best score, ties broken toward the centre.
fn choose(trace: &[TraceEntry], xs: &[Vec<f64>], search: &[(f64, f64)]) -> usize {
    let Some(best) = (0..trace.len()).max_by(|&a, &b| {
        trace[a]
            .objective
            .total_cmp(&trace[b].objective)
            .then(b.cmp(&a))
    }) else {
        return 0;
    };
    let j = trace[best].objective;
    let tol = tie_tolerance(j);
    (0..trace.len())
        .filter(|&k| trace[k].objective >= j - tol && trace[k].n_modes == trace[best].n_modes)
        .max_by(|&a, &b| {
            centrality(&xs[a], search)
                .total_cmp(&centrality(&xs[b], search))
                .then(trace[a].objective.total_cmp(&trace[b].objective))
                .then(b.cmp(&a))
        })
        .unwrap_or(best)
}
