//! The `command` kind: a user's own script as a stage, hashed like any other
//! (the escape hatch, as DVC's `cmd`). It runs `sh -c CMD` in the pipeline
//! file's directory; `deps` are files it reads (hashed into the key; a dep
//! that another stage lists in `outs` makes a DAG edge and is restored from
//! the cache before the command runs), `outs` are files it writes (collected
//! into the cache; removed before the command runs so stale files are never
//! mistaken for new ones).
//!
//! Inputs bound with `inputs:` reach the command as environment variables
//! `MODALFLOW_INPUT_<NAME>` (upper-cased; several paths joined by `:`), along
//! with `MODALFLOW_STAGE`, `MODALFLOW_SEED` and `MODALFLOW_SCRATCH`.

use super::{
    Artifact, FileRef, InputSpec, Kind, Output, ParamProblem, StageContext, StageError,
    StageOutputs,
};
use std::path::Path;
use std::process::Command as Process;

pub struct Command;

crate::params! {
    /// The `command` kind's params.
    pub struct Params {
        /// shell command, run with `sh -c` in the pipeline file's directory
        pub cmd: String,
        /// files or directories the command reads (hashed into the cache key)
        pub deps: Vec<String> = Vec::new(),
        /// files or directories the command writes (relative paths; collected
        /// into the cache)
        pub outs: Vec<String> = Vec::new(),
    }
}

impl Kind for Command {
    type Params = Params;
    const NAME: &'static str = "command";
    const FILE_PARAMS: &'static [(&'static str, bool)] = &[("deps", false)];

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "run a shell command with declared deps and outs"
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        None
    }

    /// Its `outs`.
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[];

    fn outputs(&self, p: &Params) -> Vec<Output> {
        p.outs
            .iter()
            .map(|o| Output::new(o.clone(), Artifact::Any))
            .collect()
    }

    fn workspace_outputs(&self, p: &Params) -> Vec<String> {
        p.outs.clone()
    }

    fn files(&self, p: &Params) -> Vec<FileRef> {
        p.deps
            .iter()
            .enumerate()
            .map(|(i, d)| FileRef {
                param: format!("deps[{i}]"),
                path: d.clone(),
                glob: false,
            })
            .collect()
    }

    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        let mut problems = Vec::new();
        if p.cmd.trim().is_empty() {
            problems.push(ParamProblem::new(
                &["cmd"],
                "`cmd` is empty",
                "give the shell command to run",
            ));
        }
        for (i, out) in p.outs.iter().enumerate() {
            if let Err(problem) = crate::paths::relative(out) {
                problems.push(ParamProblem::new(
                    &["outs", &i.to_string()],
                    format!("output path `{}` {problem}", out.escape_debug()),
                    "outputs are removed before the command runs and restored from the cache: \
                     name a file or folder strictly below the pipeline directory, e.g. `data/table.csv`",
                ));
            }
        }
        for (i, dep) in p.deps.iter().enumerate() {
            if dep.trim().is_empty() || dep.chars().any(char::is_control) {
                problems.push(ParamProblem::new(
                    &["deps", &i.to_string()],
                    format!(
                        "dependency path `{}` is empty or has a control character",
                        dep.escape_debug()
                    ),
                    "name a file or directory relative to the pipeline file",
                ));
            }
        }
        problems
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let cmd = p.cmd.as_str();
        for out in &p.outs {
            remove_stale_output(ctx.pipeline_dir, out)?;
        }
        let log_path = ctx.scratch.join("command.log");
        let log =
            std::fs::File::create(&log_path).map_err(|e| StageError::io("cannot create log", e))?;
        let log_err = log
            .try_clone()
            .map_err(|e| StageError::io("cannot create log", e))?;
        let mut process = Process::new("sh");
        process
            .arg("-c")
            .arg(cmd)
            .current_dir(ctx.pipeline_dir)
            .stdin(std::process::Stdio::null())
            .stdout(log)
            .stderr(log_err)
            .env("MODALFLOW_STAGE", ctx.stage)
            .env("MODALFLOW_SEED", ctx.seed.to_string())
            .env("MODALFLOW_SCRATCH", ctx.scratch);
        for (name, paths) in ctx.inputs {
            let joined: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
            let var: String = name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() {
                        c.to_ascii_uppercase()
                    } else {
                        '_'
                    }
                })
                .collect();
            process.env(format!("MODALFLOW_INPUT_{var}"), joined.join(":"));
        }
        ctx.progress
            .set_message(cmd.lines().next().unwrap_or_default().to_string());
        let status = process
            .status()
            .map_err(|e| StageError::io("cannot start `sh` (is a POSIX shell installed?)", e))?;
        if !status.success() {
            let tail = tail(&log_path, 15);
            let code = status
                .code()
                .map_or("a signal".to_string(), |c| format!("status {c}"));
            return Err(StageError::Failed(format!(
                "command `{cmd}` exited with {code}{tail}"
            )));
        }
        let mut files = Vec::new();
        for out in &p.outs {
            let path = ctx.pipeline_dir.join(out);
            if !path.exists() {
                return Err(StageError::Failed(format!(
                    "command `{cmd}` succeeded but did not write `{out}` (declared in outs); fix the command or the outs list"
                )));
            }
            files.push((out.clone(), path));
        }
        Ok(StageOutputs {
            warnings: Vec::new(),
            files,
            counters: Default::default(),
        })
    }
}

/// Remove what a previous run left at `out` (checked by the path policy
/// at validation; checked again here, since links can appear meanwhile):
/// never through a symbolic link, never the pipeline directory itself.
fn remove_stale_output(dir: &Path, out: &str) -> Result<(), StageError> {
    let rel = crate::paths::relative(out)
        .map_err(|problem| StageError::Failed(format!("output path `{out}` {problem}")))?;
    crate::paths::no_symlink_below(dir, &rel)
        .map_err(|e| StageError::io(format!("cannot remove stale output `{out}`"), e))?;
    let p = dir.join(&rel);
    let removed = match std::fs::symlink_metadata(&p) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(&p),
        Ok(_) => std::fs::remove_file(&p),
        Err(e) => Err(e),
    };
    match removed {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(StageError::io(
            format!("cannot remove stale output {}", p.display()),
            e,
        )),
        _ => Ok(()),
    }
}

fn tail(path: &Path, lines: usize) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let all: Vec<&str> = text.lines().collect();
    if all.is_empty() {
        return String::new();
    }
    let start = all.len().saturating_sub(lines);
    format!(
        "; its output ends with:\n    {}",
        all[start..].join("\n    ")
    )
}
