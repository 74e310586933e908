//! Shared pieces of command output: cache/results location flags, JSON on
//! stdout, broken-pipe detection.

use modalflow::pipeline::plan::PlanError;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Where the cache and results live; shared by every command that reads them.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Locations {
    /// Cache directory (content-addressed store). Default: `cache` in the
    /// project root — the nearest folder at or above the pipeline file's
    /// that holds a `.modalflow` marker file or a cache, else the current
    /// directory.
    #[arg(long, env = "MODALFLOW_CACHE")]
    pub cache: Option<PathBuf>,
    /// Results root; a pipeline's results go to RESULTS/<name>/. Default:
    /// `results` in the project root (see `--cache`).
    #[arg(long)]
    pub results: Option<PathBuf>,
}

/// [`Locations`] with the defaults filled in from the project root.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub cache: PathBuf,
    pub results: PathBuf,
}

impl Resolved {
    /// Serve model files' facts from this cache while planning, so
    /// validation does not build a large model whose content built before
    /// (`modalflow::stages::params::model_facts`).
    pub fn serve_model_facts(&self) {
        modalflow::stages::params::model_facts::read_from(&self.cache);
    }

    /// Keep the model facts this process learned in the cache, when it
    /// exists; call after the locations were checked.
    pub fn keep_model_facts(&self) {
        modalflow::stages::params::model_facts::save(&self.cache);
    }
}

impl Locations {
    /// The cache and results root for a pipeline file (`None`: no file,
    /// the search starts in the current directory).
    pub fn resolve(&self, file: Option<&Path>) -> Resolved {
        let cwd = PathBuf::from(".");
        let start = match file.and_then(Path::parent) {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => cwd.clone(),
        };
        let root = modalflow::pipeline::project::root(&start, &cwd);
        // Relative to the current directory when the root is it, so paths
        // in messages read as before.
        let here = std::fs::canonicalize(&cwd).ok();
        let under = |name: &str| {
            if root == cwd || Some(&root) == here.as_ref() {
                PathBuf::from(name)
            } else {
                root.join(name)
            }
        };
        Resolved {
            cache: self.cache.clone().unwrap_or_else(|| under("cache")),
            results: self.results.clone().unwrap_or_else(|| under("results")),
        }
    }
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
