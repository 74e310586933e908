//! Shared pieces of command output: cache/results location flags, JSON on
//! stdout, broken-pipe detection.

use modalflow::pipeline::plan::PlanError;
use std::io::Write;
use std::path::PathBuf;

/// Where the cache and results live; shared by every command that reads them.
#[derive(clap::Args, Clone, Debug)]
pub struct Locations {
    /// Cache directory (content-addressed store).
    #[arg(long, env = "MODALFLOW_CACHE", default_value = "cache")]
    pub cache: PathBuf,
    /// Results root; a pipeline's results go to RESULTS/<name>/.
    #[arg(long, default_value = "results")]
    pub results: PathBuf,
}

/// `--set STAGE.PARAM=VALUE`, on every command that plans the file for
/// running (`run`, `status`, `validate`).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Overrides {
    /// Override a param for this invocation (repeatable; the value is YAML,
    /// the param may be a dotted path, the stage a base name or one
    /// expansion); it enters the key like an edit of the file.
    #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
    pub set: Vec<String>,
}

/// Print one JSON object on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)?;
    writeln!(out)?;
    Ok(())
}

/// Print text on stdout (errors, e.g. a closed pipe, propagate).
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            || c.downcast_ref::<serde_json::Error>()
                .is_some_and(|j| j.io_error_kind() == Some(std::io::ErrorKind::BrokenPipe))
    })
}

/// One located problem of an invalid pipeline file in `--json` output.
#[derive(serde::Serialize)]
pub struct ProblemJson {
    pub file: String,
    pub line: Option<usize>,
    pub column: Option<usize>,
    pub message: String,
    pub help: Option<String>,
}

/// The object `--json` prints on stdout when a command fails: the error,
/// the exit code, and every problem of an invalid pipeline file (empty for
/// other errors).
#[derive(serde::Serialize)]
pub struct ErrorJson {
    pub error: String,
    pub exit_code: u8,
    pub problems: Vec<ProblemJson>,
}

pub fn error_object(e: &anyhow::Error, exit_code: u8) -> ErrorJson {
    let problems = match e.downcast_ref::<PlanError>() {
        Some(PlanError::Invalid(diags)) => diags
            .0
            .iter()
            .map(|d| ProblemJson {
                file: d.file.display().to_string(),
                line: d.location.map(|l| l.line),
                column: d.location.map(|l| l.column),
                message: d.message.clone(),
                help: d.help.clone(),
            })
            .collect(),
        _ => Vec::new(),
    };
    ErrorJson {
        error: format!("{e:#}"),
        exit_code,
        problems,
    }
}
