//! The `sbatch` resources of one stage's jobs: the fields that may appear
//! at the top of the `executor:` block, under `kinds: {KIND: …}` and under
//! `stages: {STAGE: …}` ([`Resources`]), resolved with every default
//! ([`Resolved`]), and the values that scale with the attempt of a retried
//! job (`memory: 4G * attempt`, `time: "01:00:00 * attempt"`).

use serde::{Deserialize, Deserializer};

/// Resources of one level (block, kind or stage); unset fields fall back
/// to the level below.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Resources {
    #[serde(default, deserialize_with = "text")]
    pub partition: Option<String>,
    #[serde(default, deserialize_with = "text")]
    pub account: Option<String>,
    /// `--time`; may end in `* attempt`.
    #[serde(default, deserialize_with = "text")]
    pub time: Option<String>,
    pub cpus: Option<u32>,
    /// `--mem`; may end in `* attempt`.
    #[serde(default, deserialize_with = "text")]
    pub memory: Option<String>,
    /// Array tasks a shardable stage's batch is split over (default 1).
    pub shards: Option<usize>,
    /// Run on the submitting machine instead of as a job (default false).
    pub local: Option<bool>,
    pub sbatch: Option<Vec<String>>,
    /// Resubmissions after TIMEOUT, OUT_OF_MEMORY or a node failure (default 0).
    pub retries: Option<u32>,
    /// Array tasks running at once (`--array=…%N`); default: no limit.
    pub array_parallelism: Option<usize>,
    /// Stages of this kind ready together run up to this many per job, one
    /// after another (default 1: a job each).
    pub group: Option<usize>,
    /// Node-local directory for the stage's scratch and input checkouts,
    /// expanded by the job's shell (e.g. `$TMPDIR`); default: `cache/tmp`.
    #[serde(default, deserialize_with = "text")]
    pub scratch: Option<String>,
}

/// Memory requested when no level sets `memory`: a node's whole memory is
/// what many clusters give a job without `--mem`, which blocks the node.
pub const DEFAULT_MEMORY: &str = "2G";

/// Largest `shards` accepted: Slurm's default `MaxArraySize` allows task
/// indices 0..1000.
pub const MAX_SHARDS: usize = 1000;

/// Resources of one stage with every default applied.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    pub partition: Option<String>,
    pub account: Option<String>,
    pub time: Option<String>,
    pub cpus: u32,
    pub memory: String,
    pub shards: usize,
    pub local: bool,
    pub sbatch: Vec<String>,
    pub retries: u32,
    pub array_parallelism: Option<usize>,
    pub group: usize,
    pub scratch: Option<String>,
}

impl Resources {
    /// `self` over `below`: each field set here wins.
    pub fn over(&self, below: &Resources) -> Resources {
        let s = self.clone();
        let b = below.clone();
        Resources {
            partition: s.partition.or(b.partition),
            account: s.account.or(b.account),
            time: s.time.or(b.time),
            cpus: s.cpus.or(b.cpus),
            memory: s.memory.or(b.memory),
            shards: s.shards.or(b.shards),
            local: s.local.or(b.local),
            sbatch: s.sbatch.or(b.sbatch),
            retries: s.retries.or(b.retries),
            array_parallelism: s.array_parallelism.or(b.array_parallelism),
            group: s.group.or(b.group),
            scratch: s.scratch.or(b.scratch),
        }
    }

    /// Every default applied.
    pub fn resolve(self) -> Resolved {
        Resolved {
            partition: self.partition,
            account: self.account,
            time: self.time,
            cpus: self.cpus.unwrap_or(1),
            memory: self.memory.unwrap_or_else(|| DEFAULT_MEMORY.into()),
            shards: self.shards.unwrap_or(1),
            local: self.local.unwrap_or(false),
            sbatch: self.sbatch.unwrap_or_default(),
            retries: self.retries.unwrap_or(0),
            array_parallelism: self.array_parallelism,
            group: self.group.unwrap_or(1).max(1),
            scratch: self.scratch,
        }
    }
}

impl Resolved {
    /// `--time` of attempt `attempt` (1 for the first submission).
    pub fn time_at(&self, attempt: u32) -> Option<String> {
        let t = self.time.as_deref()?;
        match scaled(t) {
            Some(base) => seconds_of(base).map(|s| format_time(s * u64::from(attempt.max(1)))),
            None => Some(t.to_string()),
        }
    }

    /// `--mem` of attempt `attempt`.
    pub fn memory_at(&self, attempt: u32) -> String {
        let m = self.memory.as_str();
        match scaled(m) {
            Some(base) => {
                let digits = base.trim_end_matches(char::is_alphabetic);
                let unit = &base[digits.len()..];
                digits.parse::<u64>().map_or_else(
                    |_| base.to_string(),
                    |n| format!("{}{unit}", n * u64::from(attempt.max(1))),
                )
            }
            None => m.to_string(),
        }
    }

    /// What must agree for stages to share one submission (an array or a
    /// group job): every `#SBATCH` line of the first attempt.
    pub fn submission_key(&self) -> String {
        format!(
            "{:?}|{:?}|{:?}|{}|{}|{:?}|{:?}|{:?}",
            self.partition,
            self.account,
            self.time_at(1),
            self.cpus,
            self.memory_at(1),
            self.sbatch,
            self.array_parallelism,
            self.scratch
        )
    }
}

/// The base of `4G * attempt` (`4G`), or `None` when the value does not scale.
fn scaled(value: &str) -> Option<&str> {
    let (base, factor) = value.split_once('*')?;
    (factor.trim() == "attempt").then_some(base.trim())
}

/// A problem in a resources mapping: which field (and which entry of a
/// list field), what, what to do.
pub struct FieldProblem {
    pub field: &'static str,
    pub index: Option<usize>,
    pub message: String,
    pub help: String,
}

/// Why a value cannot go into a job script. Every value of the block that
/// reaches the script is checked with these, at `validate` time
/// ([`problems`]) and again when the script is written
/// ([`super::script::Script::text`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Unsafe {
    /// A newline would end the `#SBATCH` line and start a shell line; no
    /// control character has a use in a resource value.
    #[error("`{field}` contains a control character ({found}): `{value}`")]
    Control {
        field: &'static str,
        value: String,
        found: String,
    },
    #[error("`sbatch` entry `{0}` is not an sbatch option")]
    NotAnOption(String),
    #[error("`scratch: {value}`: {what}")]
    Scratch { value: String, what: &'static str },
}

impl Unsafe {
    /// What to write instead.
    pub fn help(&self) -> &'static str {
        match self {
            Unsafe::Control { .. } => {
                "resource values are single-line text; a newline (or any other control \
                 character) would end the `#SBATCH` line and start a shell command"
            }
            Unsafe::NotAnOption(_) => {
                "each `sbatch` entry is one option as sbatch takes it: `--option=value`, \
                 `--option value`, `--flag` or `-x value`"
            }
            Unsafe::Scratch { .. } => SCRATCH_HELP,
        }
    }
}

const SCRATCH_HELP: &str = "a node-local directory: plain text and environment variables \
    `$NAME` or `${NAME}` expanded by the job's shell (`$TMPDIR`, `/scratch/$USER`); \
    no command substitution (`$(...)`, backticks), `\\`, `\"` or other `$` forms";

/// `value` with its control characters escaped, for messages.
pub fn shown(value: &str) -> String {
    value
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// Refuse any control character (newline, carriage return, NUL, tab, …).
pub fn no_control(field: &'static str, value: &str) -> Result<(), Unsafe> {
    match value.chars().find(|c| c.is_control()) {
        Some(c) => Err(Unsafe::Control {
            field,
            value: shown(value),
            found: c.escape_default().to_string(),
        }),
        None => Ok(()),
    }
}

/// An `sbatch:` entry: one option (`--opt`, `--opt=value`, `--opt value`,
/// `-x`, `-x value`, `-xvalue`) on one line.
pub fn sbatch_option(entry: &str) -> Result<(), Unsafe> {
    no_control("sbatch", entry)?;
    let option = if let Some(long) = entry.strip_prefix("--") {
        let name = long.split(['=', ' ']).next().unwrap_or_default();
        name.starts_with(|c: char| c.is_ascii_alphabetic())
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
    } else {
        entry
            .strip_prefix('-')
            .is_some_and(|short| short.starts_with(|c: char| c.is_ascii_alphabetic()))
    };
    if option {
        Ok(())
    } else {
        Err(Unsafe::NotAnOption(entry.to_string()))
    }
}

/// A piece of a `scratch:` value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScratchPart<'a> {
    /// Literal text: no `$`, backtick, `\`, `"` or control character.
    Text(&'a str),
    /// An environment variable's name, as written: `$NAME` (the name runs
    /// to the first character that cannot continue it, as in the shell) or
    /// `${NAME}` (`braced`).
    Var { name: &'a str, braced: bool },
}

/// `scratch:` as literal text and variable references, or why not: the job
/// script expands the variables and nothing else.
pub fn scratch_parts(value: &str) -> Result<Vec<ScratchPart<'_>>, Unsafe> {
    no_control("scratch", value)?;
    let refuse = |what| {
        Err(Unsafe::Scratch {
            value: value.to_string(),
            what,
        })
    };
    if value.trim().is_empty() {
        return refuse("it is empty");
    }
    let mut parts = Vec::new();
    let mut rest = value;
    while let Some(i) = rest.find(['$', '`', '\\', '"']) {
        if i > 0 {
            parts.push(ScratchPart::Text(&rest[..i]));
        }
        let after = &rest[i + 1..];
        match &rest[i..=i] {
            "`" => return refuse("backticks (command substitution) are not allowed"),
            "\\" => return refuse("`\\` is not allowed"),
            "\"" => return refuse("`\"` is not allowed"),
            _ => {}
        }
        let braced = after.starts_with('{');
        let (name, tail) = if let Some(inner) = after.strip_prefix('{') {
            match inner.split_once('}') {
                Some((name, tail)) => (name, tail),
                None => return refuse("`${` has no closing `}`"),
            }
        } else {
            let end = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            after.split_at(end)
        };
        if after.starts_with('(') {
            return refuse("command substitution `$(...)` is not allowed");
        }
        let variable = name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !variable {
            return refuse("`$` must start an environment variable, `$NAME` or `${NAME}`");
        }
        parts.push(ScratchPart::Var { name, braced });
        rest = tail;
    }
    if !rest.is_empty() {
        parts.push(ScratchPart::Text(rest));
    }
    Ok(parts)
}

/// `value` unless it has a control character, which is then its problem.
fn clean<'v>(
    field: &'static str,
    value: &'v Option<String>,
    bad: &mut dyn FnMut(&'static str, String, &str),
) -> Option<&'v str> {
    match value.as_deref().map(|v| no_control(field, v)) {
        Some(Err(e)) => {
            bad(field, e.to_string(), e.help());
            None
        }
        _ => value.as_deref(),
    }
}

/// Every value problem of one level.
pub fn problems(r: &Resources) -> Vec<FieldProblem> {
    let mut out = Vec::new();
    let mut bad = |field, message: String, help: &str| {
        out.push(FieldProblem {
            field,
            index: None,
            message,
            help: help.to_string(),
        })
    };
    if let Some(t) = clean("time", &r.time, &mut bad) {
        if !valid_time(scaled(t).unwrap_or(t)) {
            bad(
                "time",
                format!("`time: {t}` is not a Slurm time limit"),
                "write minutes (`30`), `HH:MM:SS` (`\"01:30:00\"`) or `D-HH:MM:SS`, \
                 optionally `* attempt` to scale it with the retry (`\"30 * attempt\"`)",
            );
        }
    }
    if let Some(m) = clean("memory", &r.memory, &mut bad) {
        if !valid_memory(scaled(m).unwrap_or(m)) {
            bad(
                "memory",
                format!("`memory: {m}` is not a Slurm memory size"),
                "write megabytes (`4000`) or a size with a unit: `512M`, `4G`, `1T`, \
                 optionally `* attempt` (`4G * attempt`)",
            );
        }
    }
    if r.cpus == Some(0) {
        bad(
            "cpus",
            "`cpus` must be at least 1".into(),
            "CPUs per task (`--cpus-per-task`); the stage's threads use them",
        );
    }
    if let Some(s) = r.shards {
        if s == 0 || s > MAX_SHARDS {
            bad(
                "shards",
                format!("`shards: {s}` is out of range"),
                "give 1 (no sharding) to 1000 array tasks",
            );
        }
    }
    if r.retries.is_some_and(|n| n > 10) {
        bad(
            "retries",
            format!("`retries: {}` is more than 10", r.retries.unwrap_or(0)),
            "resubmissions after TIMEOUT, OUT_OF_MEMORY or a node failure: 0 to 10",
        );
    }
    if r.array_parallelism == Some(0) {
        bad(
            "array_parallelism",
            "`array_parallelism` must be at least 1".into(),
            "array tasks running at once (`--array=…%N`); leave it out for no limit",
        );
    }
    if r.group.is_some_and(|g| g == 0 || g > MAX_SHARDS) {
        bad(
            "group",
            format!("`group: {}` is out of range", r.group.unwrap_or(0)),
            "stages run one after another in one job: 1 (a job each) to 1000",
        );
    }
    if let Some(Err(e)) = r.scratch.as_deref().map(scratch_parts) {
        bad("scratch", e.to_string(), e.help());
    }
    for (field, value) in [("partition", &r.partition), ("account", &r.account)] {
        if clean(field, value, &mut bad)
            .is_some_and(|v| v.is_empty() || v.chars().any(char::is_whitespace))
        {
            bad(
                field,
                format!("`{field}` must be one word"),
                "the name as `sinfo` / `sacctmgr show assoc` list it",
            );
        }
    }
    for (i, entry) in r.sbatch.iter().flatten().enumerate() {
        if let Err(e) = sbatch_option(entry) {
            out.push(FieldProblem {
                field: "sbatch",
                index: Some(i),
                message: e.to_string(),
                help: e.help().to_string(),
            });
        }
    }
    out
}

/// A string, or a number taken as its text (`time: 30`, `memory: 4000`).
fn text<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Text {
        S(String),
        N(u64),
    }
    Ok(Option::<Text>::deserialize(d)?.map(|t| match t {
        Text::S(s) => s,
        Text::N(n) => n.to_string(),
    }))
}

/// Slurm's time formats: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`.
pub fn valid_time(t: &str) -> bool {
    seconds_of(t).is_some()
}

/// Seconds of a Slurm time limit (see [`valid_time`]).
pub fn seconds_of(t: &str) -> Option<u64> {
    let number = |s: &str| -> Option<u64> {
        (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse().ok())
            .flatten()
    };
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(number(d)?), r),
        None => (None, t),
    };
    let parts: Vec<u64> = rest.split(':').map(number).collect::<Option<_>>()?;
    let s = match (days, parts.as_slice()) {
        (None, [m]) => m * 60,
        (None, [m, s]) => m * 60 + s,
        (None, [h, m, s]) | (Some(_), [h, m, s]) => h * 3600 + m * 60 + s,
        (Some(_), [h]) => h * 3600,
        (Some(_), [h, m]) => h * 3600 + m * 60,
        _ => return None,
    };
    Some(s + days.unwrap_or(0) * 86_400)
}

/// `D-HH:MM:SS`, or `HH:MM:SS` under a day.
pub fn format_time(seconds: u64) -> String {
    let (d, rest) = (seconds / 86_400, seconds % 86_400);
    let hms = format!(
        "{:02}:{:02}:{:02}",
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    );
    if d > 0 {
        format!("{d}-{hms}")
    } else {
        hms
    }
}

pub fn valid_memory(m: &str) -> bool {
    let number = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    m.len() - number.len() <= 1 && !number.is_empty() && number.bytes().all(|b| b.is_ascii_digit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_formats_and_their_seconds() {
        for (t, s) in [
            ("30", 1800),
            ("10:00", 600),
            ("01:30:00", 5400),
            ("2-00", 172_800),
            ("2-12:00:00", 216_000),
            ("1-1:30", 91_800),
        ] {
            assert_eq!(seconds_of(t), Some(s), "{t}");
        }
        for bad in ["", "1:2:3:4", "a-10", "1h"] {
            assert!(!valid_time(bad), "{bad}");
        }
        assert_eq!(format_time(5400), "01:30:00");
        assert_eq!(format_time(2 * 86_400 + 61), "2-00:01:01");
        assert!(valid_memory("4000") && valid_memory("4G") && !valid_memory("G"));
    }

    #[test]
    fn time_and_memory_scale_with_the_attempt() {
        let r = Resources {
            time: Some("30 * attempt".into()),
            memory: Some("4G*attempt".into()),
            ..Resources::default()
        }
        .resolve();
        assert_eq!(r.time_at(1).as_deref(), Some("00:30:00"));
        assert_eq!(r.time_at(3).as_deref(), Some("01:30:00"));
        assert_eq!((r.memory_at(1), r.memory_at(2)), ("4G".into(), "8G".into()));
        let fixed = Resources {
            time: Some("01:00:00".into()),
            ..Resources::default()
        }
        .resolve();
        assert_eq!(fixed.time_at(2).as_deref(), Some("01:00:00"));
        assert_eq!(fixed.memory_at(2), DEFAULT_MEMORY);
        assert!(problems(&Resources {
            time: Some("1h * attempt".into()),
            memory: Some("4G * tries".into()),
            ..Resources::default()
        })
        .iter()
        .map(|p| p.field)
        .eq(["time", "memory"]));
    }
}
