//! Structural dynamics core (issue 3): model files, body reductions,
//! assembly of M, K, B, D, the generalized eigenproblem, modal damping and
//! FRF synthesis.
//!
//! Layout: [`model_file`] (YAML schema) → [`model`] (validated model,
//! [`templates`] of table 3.1, [`beam`], [`rigid`], [`superelement`]
//! bodies) → [`assembly`] ([`craig_bampton`] reductions, block-diagonal M
//! and K₀, rank-one joint terms per [`configuration`]) → [`solve`]
//! (shift-invert [`eigen`]solver, [`modal_damping`]) → [`frf`].
//!
//! ```
//! use modalflow::dynamics::{Model, PreparedModel};
//! use modalflow::frf::FrfQuantity;
//!
//! let yaml = r#"
//! parameters:
//!   - {name: k, value: 1.0e6, lower: 1.0e5, upper: 1.0e7, scale: log, kind: stiffness}
//!   - {name: c, value: 20.0, lower: 2.0, upper: 200.0, scale: log, kind: damping}
//! bodies:
//!   - name: m
//!     rigid: {mass: 1.0, inertia: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], cg: [0, 0, 0],
//!             points: {c: [0, 0, 0]}, dofs: [x]}
//! joints:
//!   - {name: spring, a: {body: m, point: c}, connections: [{dir: x, stiffness: k, damper: c}]}
//! sensors: [{name: s, body: m, point: c, node: 1, direction: 1}]
//! excitations: [{name: f, body: m, point: c, node: 1, direction: 1}]
//! "#;
//! let no_files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
//! let model = Model::from_yaml(yaml, "sdof.yaml", &no_files)?;
//! let prepared = PreparedModel::new(&model)?; // once: reductions, factorizations
//! let values = model.true_values();
//! let sol = prepared.evaluate(0, &values, 1)?; // per parameter set: cheap, &self
//! let f = sol.frequencies_hz()[0];
//! assert!((f - 1.0e3_f64.sqrt() * 1.0e3_f64.sqrt() / (2.0 * std::f64::consts::PI)).abs() < 1e-9);
//! assert!((sol.zeta[0] - 20.0 / (2.0 * 1.0e3)).abs() < 1e-12); // ζ = c / (2 √(k m))
//! let frf = prepared.frf_superposition(&sol, FrfQuantity::Receptance, &[0.0, 100.0])?;
//! assert!((frf.channels[0].values[0].re - 1.0e-6).abs() < 1e-15); // static compliance 1/k
//! # Ok::<(), modalflow::dynamics::DynamicsError>(())
//! ```
pub mod assembly;
pub mod beam;
pub mod beam_terms;
pub mod bodies;
pub mod configuration;
pub mod constraints;
pub mod craig_bampton;
pub mod eigen;
pub mod error;
pub mod fe_body;
pub mod fill;
pub mod frf;
pub mod lanczos;
pub mod measurement;
pub mod modal_damping;
pub mod model;
pub mod model_file;
pub mod model_writer;
mod points;
pub mod reference;
pub mod residual;
pub(crate) mod resolve;
pub mod rigid;
pub mod shift;
pub mod shift_invert;
pub mod solve;
pub mod sparse;
pub mod storage;
pub mod superelement;
pub mod templates;
pub mod truncation;

pub use assembly::{Configuration, JointTerms, PreparedModel};
pub use error::DynamicsError;
pub use model::{Model, Parameter};
pub use model_file::ParameterKind;
pub use solve::{ModalSolution, ModeSelection};
pub use superelement::{directory_resolver, Resolver};
