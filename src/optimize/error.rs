//! Errors of the optimizers: invalid problems or settings (with the field
//! and the fix) and broken contracts of a user-supplied objective.

/// Everything that can go wrong when setting up or running an optimizer.
/// A failed or non-finite objective value is not an error (it counts as +∞).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OptimizeError {
    /// Parameter `index` has invalid bounds.
    #[error("bounds of parameter {index}: {message}")]
    Bounds { index: usize, message: String },

    /// The budget is zero, or a batch would exceed it (an optimizer bug).
    #[error("evaluation budget: {message}")]
    Budget { message: String },

    /// The batch objective returned the wrong number of values.
    #[error("objective returned {got} values for a batch of {expected} points")]
    ObjectiveLength { expected: usize, got: usize },

    /// A start point has the wrong length or lies outside the bounds.
    #[error("start point: {message}")]
    StartPoint { message: String },

    /// `optimizer_settings` do not match the optimizer's `*Params` (unknown
    /// key, wrong type) or hold an invalid value.
    #[error("optimizer `{optimizer}` settings: {message}")]
    Settings { optimizer: String, message: String },

    /// No optimizer of that name.
    #[error("unknown optimizer `{name}`: use one of slsqp, pso, ga")]
    UnknownOptimizer { name: String },

    /// The optimizer cannot handle constraints (only SLSQP does).
    #[error("optimizer `{optimizer}` does not support constraints: use slsqp")]
    ConstraintsUnsupported { optimizer: String },
}
