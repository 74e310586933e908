//! The pipeline engine: a YAML file of stages becomes a validated DAG
//! ([`plan`]), each stage's result is cached under a content hash of what
//! determines it ([`key`], [`store`]), and the [`scheduler`] reruns
//! only what an edit touched.

pub mod diagnostic;
pub mod execute;
pub mod executor;
pub mod gc;
pub mod graph;
pub mod key;
pub mod leftovers;
pub mod matrix;
pub mod plan;
pub mod progress;
pub mod project;
pub mod provenance;
pub mod record;
pub mod results;
pub mod roots;
pub mod scheduler;
pub mod span;
pub mod spec;
pub mod store;
pub mod trace;
pub mod verify;
