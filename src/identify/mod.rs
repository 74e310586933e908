//! Model updating by identification (seed section 2.2; PUB3 section 5.2.3,
//! PUB4 section 5.3): find the parameter values at which a model's modes
//! match reference modes.
//!
//! - [`objective`]: J(x), the weighted (1 − MAC) + NFD + NDD mismatch of
//!   paired modes over all axis positions (eq. 2.62, 2.64, 2.65).
//! - [`black_box`]: one optimizer (PSO, GA, SLSQP) over all parameters on J,
//!   evaluated in parallel batches.
//! - [`guided`]: the sensitivity-guided strategy of PUB3 — per GSA
//!   subproblem SLSQP over its significant stiffness parameters from several
//!   random starts, each parameter taken from the subproblem where it varied
//!   least, then the damping by bounded linear least squares ([`damping`]).
//!
//! Results are deterministic for a seed whatever the thread count: the only
//! parallel part is the evaluation of a batch of points.

pub mod black_box;
pub mod damping;
pub mod guided;
pub mod objective;

pub use black_box::black_box;
pub use damping::{bvls, identify_damping, DampingFit};
pub use guided::{guided, GuidedResult, SubproblemRun, SubproblemSpec};
pub use objective::{ModalObjective, Term, Weights};

/// Why an identification failed.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// The inputs or settings cannot be used (message says what and how to fix).
    #[error("{0}")]
    Invalid(String),
    /// The model could not be prepared or solved.
    #[error("model: {0}")]
    Model(String),
    /// The optimizer failed.
    #[error("optimizer: {0}")]
    Optimizer(#[from] crate::optimize::OptimizeError),
}
