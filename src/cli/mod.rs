//! Command-line front end: one module per subcommand in [`commands`], each
//! holding its clap `Args` and `exec`. Errors are printed once, as
//! `modalflow: …`, and mapped to the documented [`exit`] codes.

pub mod commands;
pub mod exit;
pub mod output;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Reproducible, content-hashed pipelines for structural-dynamics model updating.
///
/// A YAML file declares stages as a DAG; every stage result is cached under a
/// content hash, so a rerun after an edit recomputes only what changed.
#[derive(Parser)]
#[command(name = "modalflow", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Memory bound of the run (e.g. 4G, 512M): params estimated to need
    /// more are rejected at validation, and the process stops (exit 3)
    /// when its heap would grow past it. Default: half the RAM.
    #[arg(long, global = true, env = "MODALFLOW_MAX_MEMORY", value_name = "SIZE",
          value_parser = modalflow::resources::parse_size)]
    max_memory: Option<u64>,
}

#[derive(Subcommand)]
enum Command {
    Run(commands::run::Args),
    Status(commands::status::Args),
    Dag(commands::dag::Args),
    Show(commands::show::Args),
    Compare(commands::compare::Args),
    Validate(commands::validate::Args),
    Verify(commands::verify::Args),
    Gc(commands::gc::Args),
    Kinds(commands::kinds::Args),
    Exec(commands::exec::Args),
    Completions(commands::completions::Args),
}

impl Command {
    /// Whether `--json` was given: then an error is also one JSON object on
    /// stdout, so a script reading stdout always gets one.
    fn json(&self) -> bool {
        match self {
            Command::Run(a) => a.json,
            Command::Status(a) => a.json,
            Command::Show(a) => a.json,
            Command::Compare(a) => a.json,
            Command::Validate(a) => a.json,
            Command::Verify(a) => a.json,
            Command::Gc(a) => a.json,
            Command::Kinds(a) => a.json,
            Command::Dag(a) => a.json,
            Command::Exec(_) | Command::Completions(_) => false,
        }
    }
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let json = cli.command.json();
    if let Some(bytes) = cli.max_memory {
        modalflow::resources::set_memory_limit(bytes);
    }
    crate::HEAP.set_limit(modalflow::resources::memory_limit());
    let result = match cli.command {
        Command::Run(a) => commands::run::exec(a),
        Command::Status(a) => commands::status::exec(a),
        Command::Dag(a) => commands::dag::exec(a),
        Command::Show(a) => commands::show::exec(a),
        Command::Compare(a) => commands::compare::exec(a),
        Command::Validate(a) => commands::validate::exec(a),
        Command::Verify(a) => commands::verify::exec(a),
        Command::Gc(a) => commands::gc::exec(a),
        Command::Kinds(a) => commands::kinds::exec(a),
        Command::Exec(a) => commands::exec::exec(a),
        Command::Completions(a) => {
            commands::completions::exec(a, &mut <Cli as clap::CommandFactory>::command())
        }
    };
    modalflow::pipeline::leftovers::retire();
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            if output::is_broken_pipe(&e) {
                return ExitCode::from(exit::SUCCESS);
            }
            let code = exit::for_error(&e);
            eprintln!("modalflow: {e:#}");
            if json {
                // Nothing more to say if stdout is gone too.
                let _ = output::print_json(&output::error_object(&e, code));
            }
            ExitCode::from(code)
        }
    }
}
