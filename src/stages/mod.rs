//! Stage kinds: one module per kind, each a [`Kind`] with typed params
//! ([`params`]), and the one registry ([`registry`]) that lists them.
//!
//! A stage is a thin adapter between artifacts (files in the cache) and the
//! numerical core: it declares its params, inputs and outputs so the engine
//! can validate a pipeline file before anything runs, and a version constant
//! that is part of every cache key, bumped whenever the kind's results would
//! change. The contract itself ([`Stage`], [`StageContext`], [`Progress`])
//! is in [`stage`], below the engine.

pub mod autoema;
pub mod command;
pub mod evaluate;
pub mod export;
pub mod gsa;
pub mod identify;
pub mod import;
pub mod params;
pub mod report;
pub mod shard;
pub mod stage;
pub mod synthesize;

pub use params::{Field, ParamProblem, ParamSet, Range};
pub use stage::{
    expand_glob, Artifact, FileRef, InputSource, InputSpec, Kind, NoProgress, Output, Parsed,
    Progress, Stage, StageContext, StageError, StageOutputs, UpstreamWarnings,
};

/// Every stage kind, in the order `modalflow` lists them.
pub fn registry() -> &'static [&'static dyn Stage] {
    &[
        &synthesize::Synthesize,
        &import::Import,
        &autoema::AutoEma,
        &gsa::Gsa,
        &identify::Identify,
        &evaluate::Evaluate,
        &export::Export,
        &report::Report,
        &command::Command,
    ]
}

/// Look up a kind by name.
pub fn find(kind: &str) -> Option<&'static dyn Stage> {
    registry().iter().copied().find(|s| s.kind() == kind)
}
