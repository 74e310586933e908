//! One module per subcommand.

pub mod compare;
pub mod completions;
pub mod dag;
pub mod exec;
pub mod gc;
pub mod kinds;
pub mod run;
pub mod show;
pub mod status;
pub mod validate;
pub mod verify;
