//! Automated experimental modal analysis (AutoEMA, seed section 5.2.2, PUB5):
//! PolyMAX poles for every model order ([`polymax`]), stabilization between
//! consecutive orders ([`stabilization`]), hierarchical clustering of the
//! stable poles ([`clustering`]), clusters to roots with their multiplicity
//! ([`roots`]), validation of every root against the noise floor of the
//! data — duplicates, significance, repeated roots ([`significance`],
//! [`noise`]) — mode shapes by LSFD with residuals ([`lsfd`]), and the
//! hyperparameter search by Bayesian optimization over a box fitted to the
//! data ([`search`], [`hyperbox`]) maximizing the mean FRAC (eq. 2.66) of
//! the validated modes ([`selection`]). The final fit is checked for
//! residual structure above the noise ([`residual`]) and for a FRAC the
//! noise does not explain ([`adequacy`]).
//!
//! The poles are computed once for the highest order and each pole's
//! projections on the data once ([`projection`]); every hyperparameter
//! candidate only re-selects from them, so one optimization step costs
//! milliseconds even on hundreds of FRFs.

pub mod adequacy;
pub mod clustering;
pub mod design;
pub mod families;
pub mod frf_data;
pub mod hermitian;
pub mod hyperbox;
pub mod layout;
pub mod lsfd;
pub mod noise;
pub mod peak_evidence;
pub mod polymax;
pub mod projection;
pub mod refine;
pub mod residual;
pub mod roots;
pub mod search;
pub mod selection;
pub mod serial_correlation;
pub mod significance;
pub mod stabilization;
pub mod summary;
pub mod synthetic;
pub mod whitening;

pub use clustering::{cluster_poles, Cluster, ClusterParams};
pub use frf_data::{FrfData, Weighting};
pub use layout::{Layout, Reciprocity};
pub use lsfd::{lsfd, lsfd_roots, LsfdFit};
pub use polymax::{polymax, polymax_rebuild_per_order, Pole, PoleOrder, PolymaxParams};
pub use roots::Root;
pub use search::{auto_ema, AutoEmaParams, AutoEmaResult, TraceEntry, CONSENSUS_MIN_LINES};
pub use selection::{
    final_fit, select_modes, Hyperparameters, Screening, Selection, SelectionParams,
    HYPERPARAMETER_NAMES,
};
pub use significance::{Reason, Rejection};
pub use stabilization::{stabilize, PoleClass, PoleFlags, StabilizationParams};

/// Why an AutoEMA step failed.
#[derive(Debug, thiserror::Error)]
pub enum EmaError {
    /// The FRF set cannot be analysed as given (missing channels, empty band, ...).
    #[error("{0}")]
    InvalidData(String),
    /// A parameter is outside its valid range.
    #[error("parameter `{name}`: {message}")]
    InvalidParam { name: String, message: String },
    /// A normal-equation matrix lost positive definiteness: the data do not
    /// support this model order (too few lines for the order, or a band too
    /// narrow for the polynomial basis).
    #[error("ill-conditioned normal equations at model order {order}; lower `max_order` or widen `band`")]
    IllConditioned { order: usize },
    /// The companion-matrix eigenvalue solver did not converge.
    #[error("eigenvalue solver did not converge at model order {order}")]
    NoConvergence { order: usize },
}

#[cfg(test)]
mod tests;
