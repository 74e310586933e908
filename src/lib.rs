//! modalflow: reproducible, content-hashed pipelines for updating
//! structural-dynamics models of machine tools from vibration measurements.
//!
//! The engine ([`pipeline`]) runs stage kinds ([`stages`]) declared in a YAML
//! file; the numerical core (frequency-response data in [`frf`], modal models
//! in [`modal`]) knows nothing of pipelines.

pub mod artifacts;
pub mod binomial;
pub mod dense;
pub mod dynamics;
pub mod ema;
pub mod file_hash;
pub mod frf;
pub mod geometry;
pub mod heap;
pub mod identify;
pub mod io;
pub mod metrics;
pub mod modal;
pub mod numbers;
pub mod optimize;
pub mod pairing;
pub mod parameter;
pub mod paths;
pub mod pipeline;
pub mod report;
pub mod resources;
pub mod sensitivity;
pub mod simulator;
pub mod stages;
pub mod yaml;
