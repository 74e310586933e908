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
//!
//! The final steps for the point the search keeps (multiplicities over all
//! orders, refined poles, validation again) are in `refinement`.

mod refinement;

pub use refinement::{refine_selection, without_roots};

use super::clustering::{
    cluster_poles_with_dropped, Cluster, ClusterParams, Dropped, DroppedColumn,
};
use super::lsfd::{lsfd_roots, LsfdFit};
use super::noise::{cmif, noise_variance};
use super::peak_evidence::PeakEvidence;
use super::polymax::PoleOrder;
use super::projection::{FitOutcome, Projector};
use super::roots::{roots_from_clusters, Root, COINCIDENT};
use super::serial_correlation::ResidualCorrelation;
use super::significance::{Acceptance, Reason, Rejection, Validated, Validation};
use super::stabilization::{stabilize, PoleFlags, StabilizationParams};
use super::{EmaError, FrfData};

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

/// Channels, the strongest, whose residuals are pooled for the serial
/// correlation ([`Screening::serial_inflation`]).
pub const POOLED_CHANNELS: usize = 4;

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

    /// The variance inflation of each root's ΔRSS in the fit of `s` by the
    /// serial correlation of that fit's residual around the root, pooled
    /// over the [`POOLED_CHANNELS`] strongest channels
    /// ([`super::serial_correlation`]), on lines `step_hz` apart; 1 where it
    /// cannot be told.
    pub fn serial_inflation(
        &mut self,
        orders: &[PoleOrder],
        s: &Selection,
        step_hz: f64,
    ) -> Vec<f64> {
        let poles: Vec<_> = s.roots.iter().map(|r| r.pole(orders)).collect();
        let lambdas: Vec<_> = poles.iter().map(|p| p.s).collect();
        let FitOutcome::Fit(fit) = self.projector.fit(&lambdas) else {
            return vec![1.0; poles.len()];
        };
        let h2 = self.projector.h_norm2();
        let mut channels: Vec<usize> = (0..h2.len()).collect();
        channels.sort_by(|&a, &b| h2[b].total_cmp(&h2[a]).then(a.cmp(&b)));
        channels.truncate(POOLED_CHANNELS);
        let residuals = self.projector.residuals(&lambdas, &fit, &channels);
        let correlation = ResidualCorrelation::new(residuals);
        let f = &self.data.frequencies_hz;
        poles
            .iter()
            .map(|p| {
                let centre = f.partition_point(|&x| x < p.frequency_hz) as f64;
                let band =
                    super::adequacy::bandwidth_lines(p.frequency_hz, p.damping_ratio, step_hz);
                correlation.inflation(centre, band)
            })
            .collect()
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

/// The band of the data (Hz): its first and last line, 0 for none.
fn band_hz(data: &FrfData) -> (f64, f64) {
    (
        data.frequencies_hz.first().copied().unwrap_or(0.0),
        data.frequencies_hz.last().copied().unwrap_or(0.0),
    )
}

/// The stabilization tolerances of the hyperparameter point `h` on the
/// band of `data`.
fn stabilization_params(h: &Hyperparameters, data: &FrfData) -> StabilizationParams {
    StabilizationParams {
        frequency_tol: h.frequency_tol,
        damping_tol: h.damping_tol,
        mac_tol: h.mac_tol,
        max_damping: h.max_damping,
        band_hz: band_hz(data),
    }
}

/// (order index, pole index) of every stable pole of `flags`: the
/// candidates of the clustering.
fn stable_poles(flags: &[Vec<PoleFlags>]) -> Vec<(usize, usize)> {
    flags
        .iter()
        .enumerate()
        .flat_map(|(j, fl)| {
            fl.iter()
                .enumerate()
                .filter(|(_, f)| f.stable())
                .map(move |(k, _)| (j, k))
        })
        .collect()
}

/// Classify, cluster, validate and score one hyperparameter point.
pub fn select_modes(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    h: &Hyperparameters,
) -> Selection {
    let data = screening.data;
    let n_orders = orders.iter().take_while(|o| o.order <= h.max_order).count();
    let flags = stabilize(orders, n_orders, &stabilization_params(h, data));
    let candidates = stable_poles(&flags);
    let (clusters, dropped) = cluster_poles_with_dropped(
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
    let mut rejected = dropped_columns(orders, &dropped, &roots, h.cluster_distance);
    let validated = screening.validate(orders, roots);
    rejected.extend(validated.rejected);
    let mean_frac = validated.fit.mean_frac();
    let n_modes: usize = validated.roots.iter().map(|r| r.multiplicity).sum();
    Selection {
        hyperparameters: h.clone(),
        flags,
        clusters,
        objective: mean_frac - screening.params.penalty * n_modes as f64,
        roots: validated.roots,
        accepted: validated.accepted,
        rejected,
        mean_frac,
    }
}

/// The stable columns the clustering dropped ([`DroppedColumn`]) that are
/// not part of a root (none of their poles joined one and their median
/// pole coincides with none, [`COINCIDENT`]), as rejections: every stable
/// column ends as a root or with its reason in metrics.json.
fn dropped_columns(
    orders: &[PoleOrder],
    dropped: &[DroppedColumn],
    roots: &[Root],
    cluster_distance: f64,
) -> Vec<Rejection> {
    let pole = |m: &(usize, usize)| &orders[m.0].poles[m.1];
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    dropped
        .iter()
        .filter(|c| !c.members.is_empty())
        .filter_map(|c| {
            let f = median(c.members.iter().map(|m| pole(m).frequency_hz).collect());
            let z = median(c.members.iter().map(|m| pole(m).damping_ratio).collect());
            let l = crate::metrics::pole(f, z);
            let joined = roots.iter().any(|r| {
                let s = r.pole(orders).s;
                (s - l).norm() <= COINCIDENT * s.re.abs().min(l.re.abs())
                    || c.members.iter().any(|m| r.members.contains(m))
            });
            let mut distinct: Vec<usize> = c.members.iter().map(|m| m.0).collect();
            distinct.sort_unstable();
            distinct.dedup();
            (!joined).then_some(Rejection {
                frequency_hz: f,
                damping_ratio: z,
                n_orders: distinct.len(),
                reason: match c.why {
                    Dropped::Sparse { min_orders } => Reason::SparseColumn { min_orders },
                    Dropped::Wide { spread } => Reason::WideColumn {
                        spread,
                        cluster_distance,
                    },
                },
            })
        })
        .collect()
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
