//! Errors of the structural-dynamics core: model-file problems (with the file
//! name and the field path so a user can fix them) and numerical failures.

/// Everything that can go wrong when reading, preparing or evaluating a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DynamicsError {
    /// The YAML text does not match the model-file schema (unknown key, wrong
    /// type, syntax error). `location` is `line L column C` from serde.
    #[error("{file}: {location}: {message}")]
    Syntax {
        file: String,
        location: String,
        message: String,
    },

    /// A field has an invalid value (negative mass, NaN, bounds out of order,
    /// unknown name …). `field` is a path such as `bodies[2].mass`.
    #[error("{file}: field `{field}`: {message}")]
    Invalid {
        file: String,
        field: String,
        message: String,
    },

    /// An external file (Matrix Market matrix of a super-element) could not be
    /// read or parsed.
    #[error("{file}: field `{field}`: cannot read `{path}`: {message}")]
    ExternalFile {
        file: String,
        field: String,
        path: String,
        message: String,
    },

    /// The assembled mass matrix is not symmetric positive definite, so the
    /// generalized eigenproblem K φ = λ M φ is not defined. Usually a body with
    /// zero mass or inertia, or a super-element mass matrix that is singular.
    #[error("mass matrix is not positive definite (pivot {pivot}, DOF `{dof}`): give every body positive mass and inertia")]
    MassNotPositiveDefinite { pivot: usize, dof: String },

    /// K + σM is not positive definite: the stiffness matrix has a negative
    /// eigenvalue (an imported super-element stiffness that is indefinite).
    #[error("stiffness matrix is not positive semi-definite (pivot {pivot}, DOF `{dof}`): check the super-element stiffness export")]
    StiffnessIndefinite { pivot: usize, dof: String },

    /// A matrix that must be positive definite for a reduction (the interior
    /// stiffness K_ii of a Craig-Bampton body) is singular.
    #[error("body `{body}`: {message}")]
    Reduction { body: String, message: String },

    /// The parameter vector given to an evaluation has the wrong length or
    /// contains non-finite or negative values.
    #[error("parameter values: {message}")]
    Parameters { message: String },

    /// A configuration index is out of range.
    #[error("configuration {index} does not exist (model has {count})")]
    Configuration { index: usize, count: usize },

    /// The Lanczos eigensolver did not converge or a mode failed its
    /// residual check ‖Kφ − λMφ‖.
    #[error("eigensolver: {message}")]
    Lanczos { message: String },

    /// The symmetric eigensolver did not converge.
    #[error("eigensolver did not converge")]
    NoConvergence,
}

impl DynamicsError {
    /// Shorthand for [`DynamicsError::Invalid`].
    pub(crate) fn invalid(
        file: &str,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        DynamicsError::Invalid {
            file: file.to_string(),
            field: field.into(),
            message: message.into(),
        }
    }
}
