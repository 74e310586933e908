//! Structural dynamics: models, modal solution, FRF synthesis and
//! measurement simulation.

pub mod measurement;
