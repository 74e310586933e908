//! Mode selection for one point of the hyperparameter space (seed section
//! 5.2.2, PUB5, with the model selection of issue 14): stabilization of the
//! PolyMAX poles ([`super::stabilization`]), hierarchical clustering of the
//! stable ones ([`super::clustering`]), clusters to roots with their
//! multiplicity ([`super::roots`]), then duplicates, significance and
//! multiplicity against the noise floor ([`super::significance`]) on the
//! cached normal equations of LSFD ([`super::projection`]).
//!
//! The score of a hyperparameter point θ is the mean FRAC (eq. 2.66) of the
//! LSFD fit with the roots that pass validation,
//!
//! J(θ) = (1/n_ch) Σ_c FRAC(H_c, Ĥ_c(θ)) − p · n_modes(θ),
//!
//! with p = 0 by default: a root enters the fit only when the data support
//! it beyond the noise (significance) and is not a second copy of another
//! (duplicate rule), so more modes raise J only when they are real. The
//! optional per-mode penalty p of PUB5 remains for comparison.

use super::clustering::{cluster_poles, Cluster, ClusterParams};
use super::lsfd::{lsfd_roots, LsfdFit};
use super::noise::{cmif, noise_variance, peak_at};
use super::peak_evidence::PeakEvidence;
use super::polymax::{Pole, PoleOrder};
use super::projection::{FitOutcome, Projector};
use super::refine::{nested_statistic, refine_sweep};
use super::roots::{multiplicity_over_all_orders, roots_from_clusters, Root};
use super::significance::{
    chi2_isf, holds_peak, Acceptance, Reason, Rejection, Validated, Validation,
};
use super::stabilization::{stabilize, PoleFlags, StabilizationParams};
use super::{EmaError, FrfData};
use num_complex::Complex64;

/// Fraction of the median stable column of the peak-holding roots below
/// which a root kept for significance alone is dropped ([`short_columns`]).
const SHORT_COLUMN: f64 = 0.3;
/// Damping ratio from which a root's column height is not judged.
const SHORT_COLUMN_MAX_DAMPING: f64 = 0.02;

/// The tuned quantities, in the order of [`Hyperparameters::to_array`].
pub const HYPERPARAMETER_NAMES: [&str; 9] = [
    "frequency_tol",
    "damping_tol",
    "mac_tol",
    "max_damping",
    "cluster_distance",
    "min_cluster_fraction",
    "damping_weight",
    "mac_weight",
    "max_order",
];

/// One point of the hyperparameter space.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Hyperparameters {
    pub frequency_tol: f64,
    pub damping_tol: f64,
    pub mac_tol: f64,
    pub max_damping: f64,
    pub cluster_distance: f64,
    pub min_cluster_fraction: f64,
    pub damping_weight: f64,
    pub mac_weight: f64,
    pub max_order: usize,
}

impl Hyperparameters {
    pub fn to_array(&self) -> [f64; 9] {
        [
            self.frequency_tol,
            self.damping_tol,
            self.mac_tol,
            self.max_damping,
            self.cluster_distance,
            self.min_cluster_fraction,
            self.damping_weight,
            self.mac_weight,
            self.max_order as f64,
        ]
    }

    pub fn from_array(a: [f64; 9]) -> Hyperparameters {
        Hyperparameters {
            frequency_tol: a[0],
            damping_tol: a[1],
            mac_tol: a[2],
            max_damping: a[3],
            cluster_distance: a[4],
            min_cluster_fraction: a[5],
            damping_weight: a[6],
            mac_weight: a[7],
            max_order: a[8].round().max(1.0) as usize,
        }
    }
}

/// Settings of the validation that every hyperparameter point shares.
#[derive(Clone, Debug, PartialEq)]
pub struct SelectionParams {
    /// Family-wise false-alarm probability α of the significance test;
    /// 10⁻⁶ by default: measured FRFs carry some model error (hysteretic or
    /// non-proportional damping, nonlinearity) that a test at 10⁻³ calls
    /// significant at high SNR. On the test bench 10⁻⁶ removes most
    /// "shoulder" roots beside strong modes and loses no mode (README).
    pub alpha: f64,
    /// Optional objective penalty per mode (PUB5); 0 by default.
    pub penalty: f64,
}

impl Default for SelectionParams {
    fn default() -> Self {
        SelectionParams {
            alpha: 1e-6,
            penalty: 0.0,
        }
    }
}

/// What every selection of one FRF matrix shares: the poles' projections
/// and the noise floor.
pub struct Screening<'d> {
    pub data: &'d FrfData,
    pub projector: Projector<'d>,
    /// Noise variance per channel ([`noise_variance`]).
    pub noise: Vec<f64>,
    /// CMIF curves ([`cmif`]).
    pub cmif: Vec<Vec<f64>>,
    /// Their prominent peaks ([`PeakEvidence`]).
    pub evidence: PeakEvidence,
    pub params: SelectionParams,
}

impl<'d> Screening<'d> {
    pub fn new(data: &'d FrfData, params: SelectionParams) -> Screening<'d> {
        let noise = noise_variance(data);
        let cmif = cmif(data);
        // The floor of the CMIF peak count: noise power of one reference column.
        let noise_power = noise.iter().sum::<f64>() / data.n_ref().max(1) as f64;
        Screening {
            data,
            projector: Projector::new(data),
            evidence: PeakEvidence::new(&data.frequencies_hz, &cmif, noise_power),
            noise,
            cmif,
            params,
        }
    }

    /// Validate `roots` of the poles `orders` against this data's noise and
    /// peak evidence ([`Validation`]).
    pub fn validate(&mut self, orders: &[PoleOrder], roots: Vec<Root>) -> Validated {
        Validation {
            projector: &mut self.projector,
            orders,
            noise: &self.noise,
            n_out: self.data.n_out(),
            n_ref: self.data.n_ref(),
            n_lines: self.data.n_lines(),
            alpha: self.params.alpha,
            evidence: &self.evidence,
        }
        .run(roots)
    }
}

/// The modes chosen for one hyperparameter point.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    pub hyperparameters: Hyperparameters,
    /// Flags of every pole of the considered orders.
    pub flags: Vec<Vec<PoleFlags>>,
    /// Validated clusters, by frequency.
    pub clusters: Vec<Cluster>,
    /// Roots that passed validation, by frequency; each holds
    /// `multiplicity` modes.
    pub roots: Vec<Root>,
    /// Why each root was kept.
    pub accepted: Vec<Acceptance>,
    /// Roots removed or changed by validation, with the reason.
    pub rejected: Vec<Rejection>,
    pub mean_frac: f64,
    /// J(θ), the optimized score.
    pub objective: f64,
}

impl Selection {
    /// Number of modes (roots counted with their multiplicity).
    pub fn n_modes(&self) -> usize {
        self.roots.iter().map(|r| r.multiplicity).sum()
    }
}

/// Classify, cluster, validate and score one hyperparameter point.
pub fn select_modes(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    h: &Hyperparameters,
) -> Selection {
    let data = screening.data;
    let n_orders = orders.iter().take_while(|o| o.order <= h.max_order).count();
    let band = (
        data.frequencies_hz.first().copied().unwrap_or(0.0),
        data.frequencies_hz.last().copied().unwrap_or(0.0),
    );
    let flags = stabilize(
        orders,
        n_orders,
        &StabilizationParams {
            frequency_tol: h.frequency_tol,
            damping_tol: h.damping_tol,
            mac_tol: h.mac_tol,
            max_damping: h.max_damping,
            band_hz: band,
        },
    );
    let candidates: Vec<(usize, usize)> = flags
        .iter()
        .enumerate()
        .flat_map(|(j, fl)| {
            fl.iter()
                .enumerate()
                .filter(|(_, f)| f.stable())
                .map(move |(k, _)| (j, k))
        })
        .collect();
    let clusters = cluster_poles(
        orders,
        &candidates,
        &ClusterParams {
            distance_threshold: h.cluster_distance,
            min_fraction: h.min_cluster_fraction,
            damping_weight: h.damping_weight,
            mac_weight: h.mac_weight,
            n_orders,
        },
    );
    let roots = roots_from_clusters(orders, &clusters, &candidates, data.n_ref());
    let validated = screening.validate(orders, roots);
    let mean_frac = validated.fit.mean_frac();
    let n_modes: usize = validated.roots.iter().map(|r| r.multiplicity).sum();
    Selection {
        hyperparameters: h.clone(),
        flags,
        clusters,
        objective: mean_frac - screening.params.penalty * n_modes as f64,
        roots: validated.roots,
        accepted: validated.accepted,
        rejected: validated.rejected,
        mean_frac,
    }
}

/// The final steps for the chosen selection: multiplicities on the
/// evidence of every computed order
/// ([`super::roots::multiplicity_over_all_orders`]), poles refined on the
/// FRFs ([`super::refine`], two sweeps with a global refit between), and
/// validation again.
pub fn refine_selection(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    s: &Selection,
) -> Selection {
    let data = screening.data;
    let mut roots = s.roots.clone();
    // Multiplicities on the evidence of every computed order.
    let h = &s.hyperparameters;
    let flags = stabilize(
        orders,
        orders.len(),
        &StabilizationParams {
            frequency_tol: h.frequency_tol,
            damping_tol: h.damping_tol,
            mac_tol: h.mac_tol,
            max_damping: h.max_damping,
            band_hz: (
                data.frequencies_hz.first().copied().unwrap_or(0.0),
                data.frequencies_hz.last().copied().unwrap_or(0.0),
            ),
        },
    );
    let stable: Vec<(usize, usize)> = flags
        .iter()
        .enumerate()
        .flat_map(|(j, fl)| {
            fl.iter()
                .enumerate()
                .filter(|(_, f)| f.stable())
                .map(move |(k, _)| (j, k))
        })
        .collect();
    let freqs = &data.frequencies_hz;
    let step = freqs
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let cmif_peak = |m: usize, f: f64, hw: f64| {
        screening
            .cmif
            .get(m - 1)
            .is_some_and(|c| peak_at(c, freqs, f, hw.max(step)))
    };
    let m: Vec<usize> = (0..roots.len())
        .map(|k| multiplicity_over_all_orders(orders, &roots, k, &stable, data.n_ref(), &cmif_peak))
        .collect();
    for (r, m) in roots.iter_mut().zip(m) {
        r.multiplicity = m;
    }
    for _sweep in 0..2 {
        refine_roots(screening, orders, &mut roots);
    }
    let mut rejected = s.rejected.clone();
    while let Some((k, reason)) = weakest_nested(screening, orders, &roots) {
        let p = roots[k].pole(orders);
        rejected.push(Rejection {
            frequency_hz: p.frequency_hz,
            damping_ratio: p.damping_ratio,
            n_orders: roots[k].n_orders,
            reason,
        });
        roots.remove(k);
        refine_roots(screening, orders, &mut roots);
    }
    // A pole the refinement moved out of the band describes no peak of
    // these data (mimo UFSC beam: 1002.6 Hz from a 5–800 Hz band).
    let (lo, hi) = (
        data.frequencies_hz.first().copied().unwrap_or(0.0),
        data.frequencies_hz.last().copied().unwrap_or(0.0),
    );
    roots.retain(|r| {
        let p = r.pole(orders);
        let inside = (lo..=hi).contains(&p.frequency_hz);
        if !inside {
            rejected.push(Rejection {
                frequency_hz: p.frequency_hz,
                damping_ratio: p.damping_ratio,
                n_orders: r.n_orders,
                reason: Reason::OutsideBand { band_hz: (lo, hi) },
            });
        }
        inside
    });
    let validated = loop {
        let validated = screening.validate(orders, roots);
        let short = short_columns(orders, &validated.roots, &validated.accepted);
        if short.is_empty() {
            break validated;
        }
        rejected.extend(validated.rejected);
        roots = Vec::with_capacity(validated.roots.len());
        for (k, r) in validated.roots.into_iter().enumerate() {
            match short.iter().find(|(j, _)| *j == k) {
                Some(&(_, median)) => {
                    let p = r.pole(orders);
                    rejected.push(Rejection {
                        frequency_hz: p.frequency_hz,
                        damping_ratio: p.damping_ratio,
                        n_orders: r.n_orders,
                        reason: Reason::ShortColumn {
                            peak_median_orders: median,
                        },
                    });
                }
                None => roots.push(r),
            }
        }
    };
    let mean_frac = validated.fit.mean_frac();
    let n_modes: usize = validated.roots.iter().map(|r| r.multiplicity).sum();
    rejected.extend(validated.rejected);
    Selection {
        hyperparameters: s.hyperparameters.clone(),
        flags: s.flags.clone(),
        clusters: s.clusters.clone(),
        objective: mean_frac - screening.params.penalty * n_modes as f64,
        roots: validated.roots,
        accepted: validated.accepted,
        rejected,
        mean_frac,
    }
}

/// A root kept only for its significance (no CMIF peak of its own) needs a
/// stable column at least [`SHORT_COLUMN`] times the median column of the
/// roots that hold a peak: cluster size is the model-order evidence of a
/// physical pole, and automated EMA discards clusters far smaller than the
/// typical physical one (Magalhães, Cunha & Caetano 2009,
/// doi:10.1016/j.ymssp.2008.05.003; Reynders, Houbrechts & De Roeck 2012,
/// doi:10.1016/j.ymssp.2011.11.008). The significance test measures a
/// root against the random noise only; on measured data a short column
/// beside strong modes soaks up systematic error instead (mass loading of
/// a roving accelerometer, the UFSC beam shaker test: 264.1 Hz beside
/// 266.3 Hz, 14 of a median 56 orders; tool holder H11: 3236 Hz, 6 of
/// 29). Only lightly damped roots (ζ < [`SHORT_COLUMN_MAX_DAMPING`])
/// are judged so: a heavily damped pole scatters across orders by a good
/// part of its half-power band 2ζf and leaves the stabilization tolerances
/// at many orders, so its column is short though it is physical (the
/// synthetic high-damping family, ζ 5–8 %, loses true modes on this rule:
/// 13 instead of 18 successes of 20 at 5 % noise). Returns (index, median)
/// of every such root.
fn short_columns(
    orders: &[PoleOrder],
    roots: &[Root],
    accepted: &[Acceptance],
) -> Vec<(usize, usize)> {
    let mut peak: Vec<usize> = roots
        .iter()
        .zip(accepted)
        .filter(|(_, a)| matches!(a, Acceptance::CmifPeak { .. }))
        .map(|(r, _)| r.n_orders)
        .collect();
    if peak.is_empty() {
        return Vec::new();
    }
    peak.sort_unstable();
    let median = peak[peak.len() / 2];
    roots
        .iter()
        .zip(accepted)
        .enumerate()
        .filter(|(_, (r, a))| {
            matches!(a, Acceptance::Significance { .. })
                && r.pole(orders).damping_ratio < SHORT_COLUMN_MAX_DAMPING
                && (r.n_orders as f64) < SHORT_COLUMN * median as f64
        })
        .map(|(k, _)| (k, median))
        .collect()
}

/// One refinement sweep of the roots' poles ([`refine_sweep`]), roots kept
/// sorted by frequency.
fn refine_roots(screening: &mut Screening<'_>, orders: &[PoleOrder], roots: &mut [Root]) {
    let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(orders).s).collect();
    let FitOutcome::Fit(fit) = screening.projector.fit(&lambdas) else {
        return;
    };
    let new = refine_sweep(screening.data, &screening.noise, &lambdas, &fit);
    for (r, l) in roots.iter_mut().zip(new) {
        if l != r.pole(orders).s && r.column_holds(orders, l.norm() / (2.0 * std::f64::consts::PI))
        {
            let w = l.norm();
            r.refined = Some(Pole {
                s: l,
                frequency_hz: w / (2.0 * std::f64::consts::PI),
                damping_ratio: -l.re / w,
                participation: r.representative_pole(orders).participation.clone(),
            });
        }
    }
    roots.sort_by(|a, b| {
        a.pole(orders)
            .frequency_hz
            .total_cmp(&b.pole(orders).frequency_hz)
    });
}

/// The root whose nested likelihood-ratio statistic falls furthest below
/// its threshold χ²_dof(1 − α/(2 n_r)), if any falls below.
fn weakest_nested(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    roots: &[Root],
) -> Option<(usize, Reason)> {
    let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(orders).s).collect();
    let FitOutcome::Fit(fit) = screening.projector.fit(&lambdas) else {
        return None;
    };
    let n = roots.len().max(1) as f64;
    let holds = holds_peak(&screening.evidence, orders, roots, &fit, &screening.noise);
    (0..roots.len())
        .filter(|&k| !holds[k])
        .filter_map(|k| {
            let (t, dof) = nested_statistic(screening.data, &screening.noise, &lambdas, &fit, k)?;
            let threshold = chi2_isf(dof, screening.params.alpha / (2.0 * n));
            (t < threshold).then_some((
                k,
                t / threshold,
                Reason::NotSignificantNested { t, threshold },
            ))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(k, _, r)| (k, r))
}

/// The final LSFD fit (Householder QR) of a selection: shapes and the
/// reconstructed FRFs.
pub fn final_fit(
    data: &FrfData,
    orders: &[PoleOrder],
    selection: &Selection,
) -> Result<LsfdFit, EmaError> {
    let lambdas: Vec<_> = selection.roots.iter().map(|r| r.pole(orders).s).collect();
    let mult: Vec<usize> = selection.roots.iter().map(|r| r.multiplicity).collect();
    lsfd_roots(data, &lambdas, &mult)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::pole as pole_of;

    /// One root per (frequency, damping, column height), each on its own
    /// order-1 pole list entry.
    fn roots(spec: &[(f64, f64, usize)]) -> (Vec<PoleOrder>, Vec<Root>) {
        let poles = spec
            .iter()
            .map(|&(f, z, _)| Pole {
                s: pole_of(f, z),
                frequency_hz: f,
                damping_ratio: z,
                participation: vec![Complex64::new(1.0, 0.0)],
            })
            .collect();
        let orders = vec![PoleOrder { order: 1, poles }];
        let roots = spec
            .iter()
            .enumerate()
            .map(|(k, &(_, _, n))| Root {
                members: vec![(0, k)],
                representative: (0, k),
                multiplicity: 1,
                n_orders: n,
                refined: None,
            })
            .collect();
        (orders, roots)
    }

    #[test]
    fn short_columns_are_judged_on_lightly_damped_significance_roots_only() {
        // Peak roots on 40, 50, 60 orders (median 50, limit 0.3 · 50 = 15);
        // significance roots on 14 orders at ζ 0.5 % (dropped) and 5 %
        // (heavily damped: kept), on 15 orders at ζ 0.5 % (kept), and a
        // peak root on 5 orders (its own peak: kept).
        let (orders, roots) = roots(&[
            (100.0, 0.005, 40),
            (200.0, 0.005, 50),
            (300.0, 0.005, 60),
            (350.0, 0.005, 5),
            (400.0, 0.005, 14),
            (500.0, 0.05, 14),
            (600.0, 0.005, 15),
        ]);
        let peak = |f| Acceptance::CmifPeak {
            peak_hz: f,
            score: 10.0,
        };
        let sig = Acceptance::Significance { score: 10.0 };
        let accepted = vec![
            peak(100.0),
            peak(200.0),
            peak(300.0),
            peak(350.0),
            sig.clone(),
            sig.clone(),
            sig,
        ];
        // Median of 5, 40, 50, 60 (upper middle): 50.
        assert_eq!(short_columns(&orders, &roots, &accepted), vec![(4, 50)]);
        // No peak root: nothing to compare with, nothing dropped.
        let none = vec![Acceptance::Significance { score: 10.0 }; roots.len()];
        assert!(short_columns(&orders, &roots, &none).is_empty());
    }
}
