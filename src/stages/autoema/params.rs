//! The `autoema` kind's params, their cross-checks and the settings of
//! [`crate::ema::auto_ema`] they give.

use crate::ema::{
    whitening::NoiseModel, AutoEmaParams, Reciprocity, Weighting, HYPERPARAMETER_NAMES,
};
use crate::stages::params::{Numbers, TypeName};
use crate::stages::{ParamProblem, Range};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// `max_order`: a fixed order, or a range the optimization chooses from.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(untagged, expecting = "an integer or [min, max]")]
pub enum MaxOrder {
    Fixed(usize),
    Range(usize, usize),
}

impl TypeName for MaxOrder {
    fn type_name() -> String {
        "integer | [min, max]".into()
    }
}

impl Numbers for MaxOrder {
    fn numbers(&self) -> Vec<f64> {
        match *self {
            MaxOrder::Fixed(n) => vec![n as f64],
            MaxOrder::Range(a, b) => vec![a as f64, b as f64],
        }
    }
}

crate::string_enum! {
    /// Whether the transposed FRF matrix is fitted (Maxwell–Betti).
    pub enum ReciprocityParam {
        Auto = "auto",
        Always = "always",
        Never = "never",
    }
}

crate::string_enum! {
    /// PolyMAX weighting of outputs and lines.
    pub enum WeightingParam {
        Uniform = "uniform",
        Coherence = "coherence",
    }
}

crate::string_enum! {
    /// The noise model along the band.
    pub enum NoiseParam {
        Auto = "auto",
        White = "white",
        Profile = "profile",
    }
}

crate::params! {
    /// The `autoema` kind's params.
    pub struct Params {
        /// frequency band [low, high] in Hz analysed (default: all lines
        /// above 0 Hz)
        pub band: Option<(f64, f64)> = None; range Range::at_least(0.0),
        /// maximum model order: an integer, or [min, max] to let the
        /// optimization choose (default: a range fitted to the number of
        /// CMIF peaks and references)
        pub max_order: Option<MaxOrder> = None; range Range::closed(1.0, 400.0),
        /// Bayesian-optimization evaluations per position, initial design
        /// included, at least: the search goes on (up to 3×) until its
        /// result has stood for a quarter of them
        pub iterations: usize = AutoEmaParams::default().evaluations; range Range::closed(1.0, 10_000.0),
        /// Sobol design points before the Gaussian process takes over
        pub initial: usize = AutoEmaParams::default().initial; range Range::closed(1.0, 10_000.0),
        /// false-alarm probability α of the test that keeps a root only when
        /// it explains more than the noise
        pub significance: f64 = AutoEmaParams::default().selection.alpha; range Range::open(0.0, 0.5),
        /// optional objective penalty per mode as in PUB5: mean FRAC −
        /// penalty · modes (0: modes are admitted by significance instead)
        pub penalty: f64 = AutoEmaParams::default().selection.penalty; range Range::closed_open(0.0, 1.0),
        /// no effect: the search runs on a fixed Sobol design, so the
        /// modes do not depend on a seed (accepted for older pipelines)
        pub seed: Option<u64> = None,
        /// hyperparameters pinned to a value: frequency_tol, damping_tol,
        /// mac_tol, max_damping, cluster_distance, min_cluster_fraction,
        /// damping_weight, mac_weight, max_order
        pub fixed: BTreeMap<String, f64> = BTreeMap::new(); range Range::at_least(0.0),
        /// search ranges [low, high] replacing the ones fitted to the data,
        /// e.g. {max_damping: [0.05, 0.4]}
        pub bounds: BTreeMap<String, (f64, f64)> = BTreeMap::new(); range Range::at_least(0.0),
        /// PolyMAX weighting: uniform per output, or by coherence when present
        /// (the coherence is then the noise model: `noise` is taken as white)
        pub weighting: WeightingParam = WeightingParam::Uniform,
        /// noise along the band: profile whitens every fit and test by the
        /// noise's frequency profile (fourth differences of the data, in 12
        /// blocks); white takes one variance per channel; auto uses the
        /// profile where it spans more than 30× in variance (a receptance
        /// or accelerance over decades) and white noise otherwise
        pub noise: NoiseParam = NoiseParam::Auto,
        /// next-best selections of the search every mode is checked
        /// against (screened): a mode wider than 3 line spacings, with a
        /// significance score below 50, that none of them holds (within
        /// 1 %) is dropped as `no_consensus`; a mode kept for significance
        /// alone, held by fewer than half of them and scoring below the
        /// inflation of its evidence by the residual's serial correlation,
        /// as `serial_correlation` (0: neither check)
        pub consensus: usize = AutoEmaParams::default().consensus; range Range::closed(0.0, 100.0),
        /// fit references × responses as measured or transposed by
        /// reciprocity (H_ij = H_ji, same poles; shapes then at the
        /// reference DOFs): auto transposes when references outnumber
        /// responses (a roving-hammer test), always, never. Missing
        /// channels are taken from their reciprocal (unless never); then
        /// the largest complete response × reference sub-matrix is fitted
        /// and what was left out is a warning; data where that keeps less
        /// than half the channels are refused, naming the missing ones
        pub reciprocity: ReciprocityParam = ReciprocityParam::Auto,
    }
}

pub(super) struct Settings {
    pub band: Option<(f64, f64)>,
    pub weighting: Weighting,
    pub reciprocity: Reciprocity,
    pub ema: AutoEmaParams,
}

/// Checks across params: orders and ranges the types cannot say.
pub(super) fn check(p: &Params) -> Vec<ParamProblem> {
    let mut out = Vec::new();
    if let Some((lo, hi)) = p.band {
        if lo >= hi {
            out.push(ParamProblem::new(
                &["band"],
                format!("band [{lo}, {hi}] is not [low, high] with 0 <= low < high"),
                "give the band in Hz, e.g. band: [5, 400]",
            ));
        }
    }
    if let Some(MaxOrder::Range(lo, hi)) = p.max_order {
        if lo > hi {
            out.push(ParamProblem::new(
                &["max_order"],
                format!("max_order [{lo}, {hi}] is not [min, max] within 1..=400"),
                "e.g. max_order: 40 or max_order: [10, 60]",
            ));
        }
    }
    for (name, &(lo, hi)) in &p.bounds {
        if !HYPERPARAMETER_NAMES.contains(&name.as_str()) || name == "max_order" {
            out.push(ParamProblem::new(
                &["bounds", name],
                format!("no search range for `{name}`"),
                format!(
                    "known: {} (the order range is `max_order: [min, max]`)",
                    HYPERPARAMETER_NAMES[..8].join(", ")
                ),
            ));
        } else if lo > hi {
            out.push(ParamProblem::new(
                &["bounds", name],
                format!("[{lo}, {hi}] is not [low, high] with 0 <= low <= high"),
                "give the range as two numbers",
            ));
        }
    }
    for name in p.fixed.keys() {
        if !HYPERPARAMETER_NAMES.contains(&name.as_str()) {
            out.push(ParamProblem::new(
                &["fixed", name],
                format!("unknown hyperparameter `{name}`"),
                format!("known: {}", HYPERPARAMETER_NAMES.join(", ")),
            ));
        }
    }
    out
}

pub(super) fn settings(p: &Params) -> Settings {
    let mut ema = AutoEmaParams {
        evaluations: p.iterations,
        initial: p.initial,
        consensus: p.consensus,
        fixed: p.fixed.clone(),
        bounds: p.bounds.clone(),
        max_order: p.max_order.map(|m| match m {
            MaxOrder::Fixed(n) => (n, n),
            MaxOrder::Range(a, b) => (a, b),
        }),
        ..AutoEmaParams::default()
    };
    ema.selection.penalty = p.penalty;
    ema.selection.alpha = p.significance;
    ema.noise = match (p.weighting, p.noise) {
        (WeightingParam::Coherence, _) | (_, NoiseParam::White) => NoiseModel::White,
        (_, NoiseParam::Auto) => NoiseModel::Auto,
        (_, NoiseParam::Profile) => NoiseModel::Profile,
    };
    Settings {
        band: p.band,
        weighting: match p.weighting {
            WeightingParam::Uniform => Weighting::Uniform,
            WeightingParam::Coherence => Weighting::Coherence,
        },
        reciprocity: match p.reciprocity {
            ReciprocityParam::Auto => Reciprocity::Auto,
            ReciprocityParam::Always => Reciprocity::Always,
            ReciprocityParam::Never => Reciprocity::Never,
        },
        ema,
    }
}
