//! AutoEMA (seed section 5.2.2, PUB5): pole selection from the PolyMAX poles
//! of every order with eight classification and clustering hyperparameters
//! plus the maximum order, scored by the mean FRAC (eq. 2.66) of the LSFD
//! reconstruction minus a small penalty per mode, and tuned by Bayesian
//! optimization ([`crate::optimize::bayesian`]). The poles are computed once
//! for the highest order; each optimization step only re-selects.

use super::clustering::{cluster_poles, Cluster, ClusterParams};
use super::lsfd::{lsfd, LsfdFit};
use super::polymax::{polymax, PoleOrder, PolymaxParams};
use super::stabilization::{stabilize, PoleFlags, StabilizationParams};
use super::{EmaError, FrfData};
use crate::optimize::bayesian::{maximize, BayesianParams};
use std::collections::BTreeMap;

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

/// Searched on a log scale (tolerances spanning decades).
const LOG_SCALE: [bool; 9] = [true, true, true, false, true, false, false, false, false];

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

/// Search bounds of every hyperparameter for a maximum-order range.
pub fn bounds(max_order: (usize, usize)) -> [(f64, f64); 9] {
    [
        (1e-3, 0.05),
        (0.02, 0.5),
        (1e-3, 0.2),
        (0.02, 0.2),
        (2e-3, 0.1),
        (0.05, 0.6),
        (0.0, 1.0),
        (0.0, 1.0),
        (max_order.0 as f64, max_order.1 as f64),
    ]
}

/// The modes chosen for one hyperparameter point.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    pub hyperparameters: Hyperparameters,
    /// Flags of every pole of the considered orders.
    pub flags: Vec<Vec<PoleFlags>>,
    /// Validated clusters, one mode each, by frequency.
    pub clusters: Vec<Cluster>,
    pub fit: LsfdFit,
    pub mean_frac: f64,
    /// mean FRAC − penalty · modes.
    pub objective: f64,
}

/// Classify, cluster and fit for one hyperparameter point.
pub fn select_modes(
    data: &FrfData,
    orders: &[PoleOrder],
    h: &Hyperparameters,
    penalty: f64,
) -> Result<Selection, EmaError> {
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
    let lambdas: Vec<_> = clusters
        .iter()
        .map(|c| orders[c.representative.0].poles[c.representative.1].s)
        .collect();
    let fit = lsfd(data, &lambdas)?;
    let mean_frac = fit.mean_frac(data);
    Ok(Selection {
        hyperparameters: h.clone(),
        flags,
        objective: mean_frac - penalty * clusters.len() as f64,
        clusters,
        fit,
        mean_frac,
    })
}

/// Settings of [`auto_ema`].
#[derive(Clone, Debug, PartialEq)]
pub struct AutoEmaParams {
    /// Range of the maximum model order; poles are computed up to its upper end.
    pub max_order: (usize, usize),
    /// Objective evaluations of the Bayesian optimization (initial design included).
    pub evaluations: usize,
    /// Latin-hypercube points before the surrogate takes over.
    pub initial: usize,
    /// Objective penalty per mode.
    pub penalty: f64,
    pub seed: u64,
    /// Hyperparameters pinned to a value (names of [`HYPERPARAMETER_NAMES`]).
    pub fixed: BTreeMap<String, f64>,
}

impl Default for AutoEmaParams {
    fn default() -> Self {
        AutoEmaParams {
            max_order: (10, 40),
            evaluations: 40,
            initial: 12,
            penalty: 0.002,
            seed: 0,
            fixed: BTreeMap::new(),
        }
    }
}

/// One optimization step.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TraceEntry {
    pub hyperparameters: Hyperparameters,
    pub mean_frac: f64,
    pub n_modes: usize,
    pub objective: f64,
}

/// Poles of all orders, the best selection and the optimization trace.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoEmaResult {
    pub orders: Vec<PoleOrder>,
    pub best: Selection,
    pub trace: Vec<TraceEntry>,
}

/// PolyMAX up to the highest order, then Bayesian optimization of the
/// selection hyperparameters; `on_step` is called after every evaluation.
pub fn auto_ema(
    data: &FrfData,
    p: &AutoEmaParams,
    on_step: &(dyn Fn() + Sync),
) -> Result<AutoEmaResult, EmaError> {
    if p.max_order.0 == 0 || p.max_order.0 > p.max_order.1 {
        return Err(EmaError::InvalidParam {
            name: "max_order".into(),
            message: format!(
                "range [{}, {}] is empty or starts at 0",
                p.max_order.0, p.max_order.1
            ),
        });
    }
    let mut fixed = [None; 9];
    for (name, &v) in &p.fixed {
        let k = HYPERPARAMETER_NAMES
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| EmaError::InvalidParam {
                name: format!("fixed.{name}"),
                message: format!(
                    "unknown hyperparameter; known: {}",
                    HYPERPARAMETER_NAMES.join(", ")
                ),
            })?;
        if !v.is_finite() || v < 0.0 {
            return Err(EmaError::InvalidParam {
                name: format!("fixed.{name}"),
                message: format!("{v} must be finite and non-negative"),
            });
        }
        fixed[k] = Some(v);
    }
    // A one-point order range is not searched.
    if p.max_order.0 == p.max_order.1 && fixed[8].is_none() {
        fixed[8] = Some(p.max_order.0 as f64);
    }
    let orders = polymax(
        data,
        &PolymaxParams {
            max_order: fixed[8].map_or(p.max_order.1, |v| v.round().max(1.0) as usize),
        },
    )?;
    let all = bounds(p.max_order);
    let free: Vec<usize> = (0..9).filter(|&k| fixed[k].is_none()).collect();
    let search: Vec<(f64, f64)> = free
        .iter()
        .map(|&k| {
            if LOG_SCALE[k] {
                (all[k].0.ln(), all[k].1.ln())
            } else {
                all[k]
            }
        })
        .collect();
    let point = |x: &[f64]| {
        let mut a = [0.0; 9];
        for k in 0..9 {
            a[k] = fixed[k].unwrap_or(0.0);
        }
        for (&k, &v) in free.iter().zip(x) {
            a[k] = if LOG_SCALE[k] { v.exp() } else { v };
        }
        Hyperparameters::from_array(a)
    };
    let mut trace = Vec::new();
    let mut objective = |x: &[f64]| {
        let h = point(x);
        let value = match select_modes(data, &orders, &h, p.penalty) {
            Ok(s) => {
                trace.push(TraceEntry {
                    hyperparameters: h,
                    mean_frac: s.mean_frac,
                    n_modes: s.clusters.len(),
                    objective: s.objective,
                });
                s.objective
            }
            Err(_) => {
                trace.push(TraceEntry {
                    hyperparameters: h,
                    mean_frac: 0.0,
                    n_modes: 0,
                    objective: -1.0,
                });
                -1.0
            }
        };
        on_step();
        value
    };
    let best_x = if free.is_empty() {
        objective(&[]);
        Vec::new()
    } else {
        let params = BayesianParams {
            initial: p.initial,
            evaluations: p.evaluations.max(1),
            seed: p.seed,
            ..BayesianParams::default()
        };
        maximize(&mut objective, &search, &params)
            .map_err(|e| EmaError::InvalidParam {
                name: "iterations".into(),
                message: e.to_string(),
            })?
            .best
            .x
    };
    let best = select_modes(data, &orders, &point(&best_x), p.penalty)?;
    Ok(AutoEmaResult {
        orders,
        best,
        trace,
    })
}
