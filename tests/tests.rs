//! The integration tests, one binary with a module per topic (the layout of
//! ripgrep's `tests/tests.rs`): the crate is linked once instead of once per
//! topic, which is most of a cold `cargo test --release` on a small machine.
//! Each module's file sits beside this one and says what it covers.

mod util;

mod autoema;
mod autoema_real;
mod beam_sections;
mod cli;
mod docs;
mod dynamics;
mod eigensolvers;
mod engine;
mod evaluate;
mod fe_by_reference;
mod fe_formats;
mod fe_solver;
mod gsa;
mod identify;
mod import;
mod import_coherence;
mod import_modes;
mod import_units;
mod layering;
mod metrics_properties;
mod optimize;
mod path_safety;
mod pipelines;
mod quickstart;
mod reliability;
mod reporting;
mod slurm_executor;
mod slurm_scale;
mod solid_superelement;
mod studies;
mod synthesize;
mod typed_params;
mod uff_fixtures;
mod uff_robustness;
mod validation;
mod workflow;
