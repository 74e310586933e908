//! The machine-readable account of one AutoEMA result (one position): the
//! modes with their stable columns, what validation rejected and why, the
//! search box and any bound the result sits on, the noise floor, residual
//! structure above it, and whether the analysis reached its goal. The
//! `autoema` stage writes these into its metrics.json; nothing here is only
//! in a log.

use super::adequacy::bandwidth_lines;
use super::hyperbox::{AtBound, DataSummary};
use super::layout::Layout;
use super::residual::ResidualPeak;
use super::search::{AutoEmaResult, TraceEntry};
use super::selection::{Hyperparameters, HYPERPARAMETER_NAMES};
use super::significance::{Acceptance, Rejection};
use num_complex::Complex64;
use std::collections::BTreeMap;

/// One identified mode.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModeSummary {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// Modes at this root (≥ 2: a repeated root; its shapes span the subspace).
    pub multiplicity: usize,
    /// Model orders in the root's stable column.
    pub stable_orders: usize,
    /// Half-power band 2ζf in line spacings ([`super::adequacy`]): below
    /// about 2 the line spacing biases the damping, below 1 the lines cannot
    /// show the peak.
    pub bandwidth_lines: f64,
    /// How many of the search's next-best selections (`consensus_of` of
    /// the position), screened, hold this mode within 1 %.
    pub support: Option<usize>,
    /// How much the serial correlation of the fit's residual around the
    /// mode inflates the variance of its ΔRSS ([`super::serial_correlation`];
    /// 1: the residual there is as good as independent from line to line).
    /// A mode kept for significance alone needs a score above it, or the
    /// support of half the next-best selections.
    pub serial_inflation: Option<f64>,
    /// Why it was kept: its own CMIF peak, or significance alone.
    #[serde(flatten)]
    pub acceptance: Option<Acceptance>,
}

/// Noise of the data: the additive floor relative to each channel's RMS,
/// and the relative error ε at the resonances
/// ([`super::noise::relative_noise`]; the residual check uses
/// σ² = σ_c² + ε²|H|²).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct NoiseSummary {
    pub median_relative: f64,
    pub max_relative: f64,
    pub relative_error: f64,
}

/// Everything metrics.json says about one position.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PositionSummary {
    pub index: u32,
    pub label: String,
    pub goal_reached: bool,
    /// How references and responses were fitted ([`super::layout`]).
    pub layout: Layout,
    pub mean_frac: f64,
    pub objective: f64,
    pub n_modes: usize,
    /// Next-best selections each mode was checked against
    /// ([`ModeSummary::support`]).
    pub consensus_of: usize,
    pub modes: Vec<ModeSummary>,
    pub rejected: Vec<Rejection>,
    pub hyperparameters: Hyperparameters,
    /// Search range of every hyperparameter (a point when fixed).
    pub bounds: BTreeMap<String, [f64; 2]>,
    pub at_bound: Vec<AtBound>,
    pub data: DataSummary,
    pub noise: NoiseSummary,
    pub residual_peaks: Vec<ResidualPeak>,
    pub warnings: Vec<String>,
    pub trace: Vec<TraceEntry>,
}

fn noise_summary(h: &[Complex64], n_lines: usize, noise: &[f64], misfit: f64) -> NoiseSummary {
    let mut rel: Vec<f64> = noise
        .iter()
        .enumerate()
        .map(|(c, s2)| {
            let p = h[c * n_lines..(c + 1) * n_lines]
                .iter()
                .map(Complex64::norm_sqr)
                .sum::<f64>()
                / n_lines.max(1) as f64;
            if p > 0.0 {
                (s2 / p).sqrt()
            } else {
                0.0
            }
        })
        .collect();
    rel.sort_by(f64::total_cmp);
    NoiseSummary {
        median_relative: rel.get(rel.len() / 2).copied().unwrap_or(0.0),
        max_relative: rel.last().copied().unwrap_or(0.0),
        relative_error: misfit,
    }
}

impl PositionSummary {
    pub fn of(
        index: u32,
        label: &str,
        h: &[Complex64],
        n_lines: usize,
        layout: &Layout,
        r: &AutoEmaResult,
    ) -> PositionSummary {
        let mut warnings = layout.warnings();
        warnings.extend(r.warnings.iter().cloned());
        PositionSummary {
            index,
            label: label.to_string(),
            goal_reached: r.goal_reached(),
            layout: layout.clone(),
            mean_frac: r.best.mean_frac,
            objective: r.best.objective,
            n_modes: r.best.n_modes(),
            consensus_of: r.consensus_of,
            modes: r
                .best
                .roots
                .iter()
                .enumerate()
                .map(|(k, root)| {
                    let p = root.pole(&r.orders);
                    ModeSummary {
                        frequency_hz: p.frequency_hz,
                        damping_ratio: p.damping_ratio,
                        multiplicity: root.multiplicity,
                        stable_orders: root.n_orders,
                        bandwidth_lines: bandwidth_lines(
                            p.frequency_hz,
                            p.damping_ratio,
                            r.summary.line_spacing_hz,
                        ),
                        support: r.support.get(k).copied(),
                        serial_inflation: r.serial_inflation.get(k).copied(),
                        acceptance: r.best.accepted.get(k).cloned(),
                    }
                })
                .collect(),
            rejected: r.best.rejected.clone(),
            hyperparameters: r.best.hyperparameters.clone(),
            bounds: HYPERPARAMETER_NAMES
                .iter()
                .zip(r.bounds)
                .map(|(n, b)| (n.to_string(), [b.0, b.1]))
                .collect(),
            at_bound: r.at_bound.clone(),
            data: r.summary.clone(),
            noise: noise_summary(h, n_lines, &r.noise, r.relative_error),
            residual_peaks: r.residual_peaks.clone(),
            warnings,
            trace: r.trace.clone(),
        }
    }
}
