//! Model updating by identification (seed section 2.2; PUB3 section 5.2.3,
//! PUB4 section 5.3): find the parameter values at which a model's modes
//! match reference modes.
//!
//! - [`updating`]: the whole update, whatever the strategy: reference and
//!   model paired by physics at the start ([`correspondence`], with the
//!   observability criterion), the strategy, then the assessment at the
//!   result: [`identifiability`] with standard errors, and a [`verdict`].
//! - [`objective`]: J(x), the weighted (1 − MAC) + NFD + NDD mismatch of
//!   paired modes over all axis positions (eq. 2.62, 2.64, 2.65), and the
//!   least-squares residuals weighted by the reference's uncertainty.
//! - [`black_box`]: one optimizer (PSO, GA, SLSQP) over all parameters on J,
//!   evaluated in parallel batches.
//! - [`guided`]: the sensitivity-guided strategy of PUB3 — per GSA
//!   mode-shape subproblem ([`subproblem`]) SLSQP over its significant
//!   stiffness parameters from several random starts, each parameter taken
//!   from the subproblem where it varied least, a joint refinement of those
//!   parameters by the mode-set [`continuation`], then the damping by
//!   bounded linear least squares ([`damping`]).
//! - [`history`]: best-so-far records with the mean MAC reached.
//!
//! Results are deterministic for a seed whatever the thread count: the only
//! parallel part is the evaluation of a batch of points.

pub mod assessment;
pub mod batch_means;
pub mod black_box;
pub mod consider;
pub mod continuation;
pub mod correspondence;
pub mod curvature;
pub mod damping;
pub mod follow_up;
pub mod frf_objective;
pub mod frf_refinement;
pub mod guided;
pub mod history;
pub mod identifiability;
pub mod joint_effect;
pub mod local_misfit;
pub mod objective;
pub mod subproblem;
pub mod updating;
pub mod verdict;
pub mod window_search;

pub use black_box::{black_box, BlackBoxResult};
pub use continuation::ContinuationParams;
pub use correspondence::{Correspondence, NamedMode, Observability};
pub use damping::{bvls, identify_damping, DampingFit};
pub use follow_up::{FollowUpKind, FollowUpRecord};
pub use guided::{guided, GuidedParams, GuidedResult, Screening};
pub use history::{HistoryRow, Recorder};
pub use identifiability::Identifiability;
pub use objective::{ModalObjective, ModeSet, Term, Uncertainty, Weights};
pub use subproblem::{Starts, SubproblemRun, SubproblemSpec};
pub use updating::{update, Plan, Strategy, Update};
pub use verdict::Verdict;

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
