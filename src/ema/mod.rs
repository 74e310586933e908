//! Automated experimental modal analysis (AutoEMA, seed section 5.2.2, PUB5):
//! PolyMAX poles for every model order ([`polymax`]), stabilization between
//! consecutive orders ([`stabilization`]), hierarchical clustering of the
//! stable poles ([`clustering`]), mode shapes by LSFD with residuals
//! ([`lsfd`]) and the hyperparameter search by Bayesian optimization that
//! maximizes the mean FRAC (eq. 2.66) of the reconstructed FRFs
//! ([`selection`]).
//!
//! The poles are computed once for the highest order; every hyperparameter
//! candidate only re-selects from them, so one optimization step costs
//! milliseconds.

pub mod clustering;
pub mod frf_data;
pub mod lsfd;
pub mod polymax;
pub mod selection;
pub mod stabilization;
pub mod stabilization_diagram;
pub mod synthetic;

pub use clustering::{cluster_poles, Cluster, ClusterParams};
pub use frf_data::{FrfData, Weighting};
pub use lsfd::{lsfd, LsfdFit};
pub use polymax::{polymax, polymax_rebuild_per_order, Pole, PoleOrder, PolymaxParams};
pub use selection::{
    auto_ema, select_modes, AutoEmaParams, AutoEmaResult, Hyperparameters, Selection,
    HYPERPARAMETER_NAMES,
};
pub use stabilization::{stabilize, PoleFlags, StabilizationParams};

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
