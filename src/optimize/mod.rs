//! Optimizers for model updating (seed section 2.2): a bounded problem in
//! the unit box with a batch objective ([`problem`]), SLSQP with
//! finite-difference gradients ([`slsqp`], [`multistart`]), particle swarm
//! optimization ([`pso`], eq. 2.25–2.26), a real-coded genetic algorithm
//! ([`ga`]), selectable by name through [`optimizer::Optimizer`]; bounded
//! Levenberg–Marquardt for residual vectors ([`levenberg_marquardt`], the
//! joint refinement of the guided identification); and
//! Gaussian-process regression ([`gaussian_process`]) with Bayesian
//! optimization by expected improvement ([`bayesian`]) for cheap-to-count,
//! expensive-to-evaluate objectives such as AutoEMA's hyperparameters.
//!
//! The numerical core knows nothing of pipelines or models: a stage builds a
//! [`problem::Problem`] around its objective and calls an optimizer.

pub mod bayesian;
pub mod error;
pub mod ga;
pub mod gaussian_process;
pub mod jacobian;
pub mod levenberg_marquardt;
pub mod multistart;
pub mod optimizer;
pub mod problem;
pub mod pso;
pub mod slsqp;

pub use error::OptimizeError;
pub use optimizer::Optimizer;
pub use problem::{
    Bounds, Constraint, Evaluator, HistoryPoint, Objective, OptimizeResult, Problem, Termination,
};
