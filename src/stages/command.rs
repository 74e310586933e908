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

use super::{ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs};
use serde_yaml_ng::{Mapping, Value};
use std::path::Path;
use std::process::Command as Process;

pub struct Command;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "cmd",
        ty: ParamType::String,
        required: true,
        doc: "shell command, run with `sh -c` in the pipeline file's directory",
    },
    ParamSpec {
        name: "deps",
        ty: ParamType::Paths,
        required: false,
        doc: "files or directories the command reads (hashed into the cache key)",
    },
    ParamSpec {
        name: "outs",
        ty: ParamType::Strings,
        required: false,
        doc: "files or directories the command writes (relative paths; collected into the cache)",
    },
];

fn outs(params: &Mapping) -> Vec<String> {
    params
        .get("outs")
        .and_then(Value::as_sequence)
        .map(|s| {
            s.iter()
                .filter_map(Value::as_str)
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

impl Stage for Command {
    fn kind(&self) -> &'static str {
        "command"
    }

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "run a shell command with declared deps and outs"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn inputs(&self) -> Option<&'static [super::InputSpec]> {
        None
    }

    fn outputs(&self, params: &Mapping) -> Vec<String> {
        outs(params)
    }

    fn workspace_outputs(&self, params: &Mapping) -> Vec<String> {
        outs(params)
    }

    fn check(&self, params: &Mapping) -> Result<(), ParamProblem> {
        for (i, out) in outs(params).iter().enumerate() {
            let p = Path::new(out);
            let escapes = p
                .components()
                .any(|c| matches!(c, std::path::Component::ParentDir));
            if p.is_absolute() || escapes || out.trim().is_empty() {
                return Err(ParamProblem {
                    path: vec!["outs".into(), i.to_string()],
                    message: format!("output path `{out}` must be relative and stay below the pipeline directory"),
                    help: Some("write outputs next to the pipeline file, e.g. `data/table.csv`".into()),
                });
            }
        }
        Ok(())
    }

    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let cmd = ctx
            .params
            .get("cmd")
            .and_then(Value::as_str)
            .unwrap_or_default();
        let outs = outs(ctx.params);
        for out in &outs {
            let p = ctx.pipeline_dir.join(out);
            let removed = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
            if let Err(e) = removed {
                if e.kind() != std::io::ErrorKind::NotFound {
                    return Err(StageError::io(
                        format!("cannot remove stale output {}", p.display()),
                        e,
                    ));
                }
            }
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
        for out in outs {
            let p = ctx.pipeline_dir.join(&out);
            if !p.exists() {
                return Err(StageError::Failed(format!(
                    "command `{cmd}` succeeded but did not write `{out}` (declared in outs); fix the command or the outs list"
                )));
            }
            files.push((out, p));
        }
        Ok(StageOutputs {
            files,
            counters: Default::default(),
        })
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
