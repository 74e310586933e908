//! Batch scripts: the `#SBATCH` lines of a stage's resources at an attempt,
//! then `modalflow exec` on one description (a job), one per array task (a
//! shard array, an array of matrix expansions), or several in turn (a
//! group job).
//!
//! No value reaches the script unchecked. `#SBATCH` lines are read by
//! sbatch, not by the shell, but a newline in one would start a shell
//! line: every value there is refused if it has a control character and
//! quoted for sbatch's parser if it has a space, quote, `\` or `#`
//! ([`sbatch_word`]); `sbatch:` entries must be options. The job name is
//! reduced to a safe alphabet and the comment line loses its control
//! characters (stage names carry matrix values). Shell words are single
//! quoted ([`quote`]), except `scratch:`, which becomes a double-quoted word
//! in which only variables (`$NAME`, `${NAME}`) expand ([`scratch_word`]).

use super::resources::{
    self, no_control, sbatch_option, scratch_parts, shown, Resolved, ScratchPart, Unsafe,
};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Why a script was not written.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    #[error("{0}; {help}", help = .0.help())]
    Unsafe(#[from] Unsafe),
    #[error("`{field}: {value}` is not a valid sbatch value")]
    Invalid { field: &'static str, value: String },
    #[error("the {what} path `{path}` contains a control character; sbatch cannot take it")]
    PathControl { what: &'static str, path: String },
    #[error("the {what} path `{path}` is not valid UTF-8; a job script cannot name it")]
    NotUtf8 { what: &'static str, path: String },
}

/// What one script runs.
pub enum Body<'a> {
    /// One description; `shards`: run task `$SLURM_ARRAY_TASK_ID` of it.
    One { description: &'a Path, shards: bool },
    /// Array task i runs description i.
    PerTask(&'a [PathBuf]),
    /// Every description in turn, in one job.
    Group(&'a [PathBuf]),
}

/// One batch script.
pub struct Script<'a> {
    pub name: &'a str,
    /// Working directory; logs go to `log/` below it.
    pub dir: &'a Path,
    pub resources: &'a Resolved,
    pub attempt: u32,
    /// Array task indices, or `None` for a single job.
    pub tasks: Option<&'a [usize]>,
    pub binary: &'a Path,
    pub cache: &'a Path,
    pub body: Body<'a>,
}

impl Script<'_> {
    /// The script, or why a value cannot go into it.
    pub fn text(&self) -> Result<String, ScriptError> {
        let r = self.resources;
        let log = match self.tasks {
            Some(_) => "%A_%a.out",
            None => "%j.out",
        };
        let mut lines = vec![
            format!("--job-name=modalflow:{}", job_name(self.name)),
            format!(
                "--chdir={}",
                sbatch_word(sbatch_path("job directory", self.dir)?)
            ),
            format!(
                "--output={}",
                sbatch_word(sbatch_path("log", &self.dir.join("log").join(log))?)
            ),
            format!("--cpus-per-task={}", r.cpus),
        ];
        if let Some(tasks) = self.tasks {
            let throttle = r
                .array_parallelism
                .map(|n| format!("%{n}"))
                .unwrap_or_default();
            lines.push(format!("--array={}{throttle}", array_spec(tasks)));
        }
        // The values as written, then as scaled for the attempt.
        no_control("memory", &r.memory)?;
        if let Some(time) = &r.time {
            no_control("time", time)?;
        }
        let memory = r.memory_at(self.attempt);
        no_control("memory", &memory)?;
        if !resources::valid_memory(&memory) {
            return Err(ScriptError::Invalid {
                field: "memory",
                value: memory,
            });
        }
        lines.push(format!("--mem={memory}"));
        if let Some(time) = r.time_at(self.attempt) {
            no_control("time", &time)?;
            if !resources::valid_time(&time) {
                return Err(ScriptError::Invalid {
                    field: "time",
                    value: time,
                });
            }
            lines.push(format!("--time={time}"));
        }
        for (opt, value) in [("partition", &r.partition), ("account", &r.account)] {
            if let Some(v) = value {
                no_control(opt, v)?;
                lines.push(format!("--{opt}={}", sbatch_word(v)));
            }
        }
        for extra in &r.sbatch {
            sbatch_option(extra)?;
            lines.push(extra.clone());
        }
        let mut exec = format!(
            "{} exec --cache {}",
            shell_path("modalflow binary", self.binary)?,
            shell_path("cache", self.cache)?
        );
        if let Some(s) = &r.scratch {
            let _ = write!(exec, " --scratch {}", scratch_word(s)?);
        }

        let mut t = String::from("#!/bin/sh\n");
        for l in &lines {
            let _ = writeln!(t, "#SBATCH {l}");
        }
        let _ = writeln!(
            t,
            "# modalflow {} (attempt {})",
            comment(self.name),
            self.attempt
        );
        let _ = writeln!(
            t,
            "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\""
        );
        match &self.body {
            Body::One {
                description,
                shards,
            } => {
                let _ = write!(t, "exec {exec} {}", shell_path("job", description)?);
                if *shards {
                    t.push_str(" --shard \"$SLURM_ARRAY_TASK_ID\"");
                }
                t.push('\n');
            }
            Body::PerTask(descriptions) => {
                t.push_str("case \"$SLURM_ARRAY_TASK_ID\" in\n");
                for (i, d) in descriptions.iter().enumerate() {
                    let _ = writeln!(t, "  {i}) job={} ;;", shell_path("job", d)?);
                }
                t.push_str(
                    "  *) echo \"no job for task $SLURM_ARRAY_TASK_ID\" >&2; exit 1 ;;\nesac\n",
                );
                let _ = writeln!(t, "exec {exec} \"$job\"");
            }
            Body::Group(descriptions) => {
                let list = descriptions
                    .iter()
                    .map(|d| shell_path("job", d))
                    .collect::<Result<Vec<_>, _>>()?;
                let _ = writeln!(t, "exec {exec} {}", list.join(" "));
            }
        }
        Ok(t)
    }
}

/// A job name Slurm shows as is: `[A-Za-z0-9._:=,[]-]`, anything else `_`.
fn job_name(stage: &str) -> String {
    stage
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.,:=[]".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A stage name for the script's comment line: control characters (a
/// newline would end the comment) become `_`.
fn comment(stage: &str) -> String {
    stage
        .chars()
        .map(|c| if c.is_control() { '_' } else { c })
        .collect()
}

/// One value of an `#SBATCH` line as sbatch's parser reads it: as is when
/// it has no space, quote, `\` or `#`, else in double quotes with `\`,
/// `"` and `#` escaped by `\` (Slurm's `_get_argument`, old and new). The
/// value has no control character ([`no_control`]).
pub fn sbatch_word(value: &str) -> String {
    if !value.contains(|c: char| c.is_whitespace() || "\"'\\#".contains(c)) {
        return value.to_string();
    }
    let mut w = String::from("\"");
    for c in value.chars() {
        if "\"\\#".contains(c) {
            w.push('\\');
        }
        w.push(c);
    }
    w.push('"');
    w
}

/// A path for an `#SBATCH` line: UTF-8 without control characters.
fn sbatch_path<'p>(what: &'static str, path: &'p Path) -> Result<&'p str, ScriptError> {
    let text = path.to_str().ok_or_else(|| ScriptError::NotUtf8 {
        what,
        path: path.display().to_string(),
    })?;
    if text.contains(char::is_control) {
        return Err(ScriptError::PathControl {
            what,
            path: shown(text),
        });
    }
    Ok(text)
}

/// A path as one single-quoted shell word (UTF-8: a lossy conversion would
/// name another file).
fn shell_path(what: &'static str, path: &Path) -> Result<String, ScriptError> {
    path.to_str()
        .map(quote)
        .ok_or_else(|| ScriptError::NotUtf8 {
            what,
            path: path.display().to_string(),
        })
}

/// `scratch:` as one double-quoted shell word in which only variables
/// (`$NAME`, `${NAME}`) expand: the value is refused unless every `$` starts
/// a variable name and it has no backtick, `\`, `"` or control character.
pub fn scratch_word(value: &str) -> Result<String, Unsafe> {
    let mut w = String::from("\"");
    for part in scratch_parts(value)? {
        match part {
            ScratchPart::Text(text) => w.push_str(text),
            // As written: `$NAME` ends where the shell ends it too.
            ScratchPart::Var { name, braced: true } => {
                let _ = write!(w, "${{{name}}}");
            }
            ScratchPart::Var {
                name,
                braced: false,
            } => {
                let _ = write!(w, "${name}");
            }
        }
    }
    w.push('"');
    Ok(w)
}

/// `0-3,5,7-8` from sorted task indices.
pub fn array_spec(tasks: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            tasks[i].to_string()
        } else {
            format!("{}-{}", tasks[i], tasks[j])
        });
        i = j + 1;
    }
    parts.join(",")
}

/// Text as one single-quoted shell word (`'` as `'\\''`): nothing in it
/// expands, newlines included.
pub fn quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::executor::resources::Resources;
    use std::process::Command;

    #[test]
    fn array_specs_compress_runs() {
        assert_eq!(array_spec(&[0, 1, 2, 3]), "0-3");
        assert_eq!(array_spec(&[1, 3, 4, 5, 9]), "1,3-5,9");
        assert_eq!(array_spec(&[7]), "7");
        assert_eq!(quote("/a b/it's"), "'/a b/it'\\''s'");
    }

    #[test]
    fn scripts_carry_throttle_attempt_resources_and_scratch() {
        let r = Resources {
            time: Some("10 * attempt".into()),
            memory: Some("1G * attempt".into()),
            array_parallelism: Some(2),
            scratch: Some("$TMPDIR".into()),
            ..Resources::default()
        }
        .resolve();
        let d = [
            PathBuf::from("/c/jobs/a/job.json"),
            PathBuf::from("/c/jobs/b/job.json"),
        ];
        let s = Script {
            name: "ident",
            dir: Path::new("/c/jobs/batch-1"),
            resources: &r,
            attempt: 2,
            tasks: Some(&[0, 1]),
            binary: Path::new("/bin/modalflow"),
            cache: Path::new("/c"),
            body: Body::PerTask(&d),
        }
        .text()
        .expect("a plain script");
        for want in [
            "#SBATCH --chdir=/c/jobs/batch-1\n",
            "#SBATCH --output=/c/jobs/batch-1/log/%A_%a.out\n",
            "#SBATCH --array=0-1%2\n",
            "#SBATCH --mem=2G\n",
            "#SBATCH --time=00:20:00\n",
            "  1) job='/c/jobs/b/job.json' ;;\n",
            "exec '/bin/modalflow' exec --cache '/c' --scratch \"$TMPDIR\" \"$job\"\n",
        ] {
            assert!(s.contains(want), "{want} in\n{s}");
        }
    }

    const INJECT: &str = "x\nrm -rf /tmp/decoy";

    /// Sets one field of the resources to a hostile value.
    type Setter<'a> = dyn Fn(&mut Resolved) + 'a;

    fn script_of(r: &Resolved, name: &str, dir: &Path) -> Result<String, ScriptError> {
        Script {
            name,
            dir,
            resources: r,
            attempt: 1,
            tasks: None,
            binary: Path::new("/bin/modalflow"),
            cache: Path::new("/c"),
            body: Body::One {
                description: Path::new("/c/jobs/k/job.json"),
                shards: false,
            },
        }
        .text()
    }

    #[test]
    fn control_characters_in_sbatch_values_are_refused() {
        let hostile = |set: &Setter<'_>| {
            let mut r = Resources::default().resolve();
            set(&mut r);
            script_of(&r, "s", Path::new("/c/jobs/k"))
        };
        for bad in [INJECT, "x\rid", "x\0y", "x\u{1b}[2J"] {
            let cases: [(&str, &Setter<'_>); 6] = [
                ("partition", &|r| r.partition = Some(bad.into())),
                ("account", &|r| r.account = Some(bad.into())),
                ("sbatch", &|r| r.sbatch = vec![format!("--qos={bad}")]),
                ("time", &|r| r.time = Some(format!("10{bad}"))),
                ("memory", &|r| r.memory = format!("4G{bad}")),
                ("scratch", &|r| r.scratch = Some(format!("/s/{bad}"))),
            ];
            for (field, set) in cases {
                let err = hostile(set).expect_err(field).to_string();
                assert!(err.contains(&format!("`{field}")), "{field}: {err}");
                assert!(!err.contains('\n'), "{field}: {err:?}");
            }
        }
        // A scaled value with a newline before `* attempt`.
        let err = hostile(&|r| r.time = Some("10\n* attempt".into()));
        assert!(err.is_err());
        let err = script_of(
            &Resources::default().resolve(),
            "s",
            Path::new("/c/jobs/k\ntouch /tmp/decoy"),
        )
        .expect_err("a job directory with a newline");
        assert!(err.to_string().contains("job directory"), "{err}");
    }

    #[test]
    fn sbatch_entries_must_be_options_and_scratch_only_expands_variables() {
        for ok in [
            "--qos=short",
            "--exclusive",
            "--gres gpu:1",
            "-C intel",
            "-Cintel",
        ] {
            assert_eq!(sbatch_option(ok), Ok(()), "{ok}");
        }
        for bad in [
            "rm -rf /tmp/decoy",
            "qos=short",
            "--",
            "-",
            "--=x",
            "- x",
            "--9x",
            "",
        ] {
            assert!(
                matches!(sbatch_option(bad), Err(Unsafe::NotAnOption(_))),
                "{bad}"
            );
        }
        for (ok, word) in [
            ("$TMPDIR", "\"$TMPDIR\""),
            (
                "/scratch/$USER/${SLURM_JOB_ID}_x",
                "\"/scratch/$USER/${SLURM_JOB_ID}_x\"",
            ),
            ("/s/it's a;dir|&<>*?~!{}", "\"/s/it's a;dir|&<>*?~!{}\""),
            ("$_a1.x", "\"$_a1.x\""),
        ] {
            assert_eq!(scratch_word(ok).as_deref(), Ok(word), "{ok}");
        }
        for (bad, why) in [
            ("$(touch /tmp/pwned)", "`$(...)`"),
            ("`touch /tmp/pwned`", "backticks"),
            ("/s/a\\b", "`\\`"),
            ("/s/\"", "`\"`"),
            ("${X:-$(id)}", "`$NAME` or `${NAME}`"),
            ("${X", "no closing"),
            ("$1", "`$NAME`"),
            ("$$", "`$NAME`"),
            ("/s/$", "`$NAME`"),
            ("${}", "`$NAME`"),
            ("  ", "empty"),
        ] {
            let err = scratch_word(bad).expect_err(bad);
            assert!(matches!(err, Unsafe::Scratch { .. }), "{bad}: {err:?}");
            assert!(err.to_string().contains(why), "{bad}: {err}");
            assert!(err.help().contains("`$NAME` or `${NAME}`"), "{bad}");
        }
    }

    /// The arguments of sbatch's `#SBATCH` lines, as Slurm's
    /// `_get_argument` splits them (quotes, `\` escapes, `#` comments).
    fn sbatch_args(script: &str) -> Vec<String> {
        let mut out = Vec::new();
        for line in script.lines() {
            let Some(mut rest) = line.strip_prefix("#SBATCH") else {
                continue;
            };
            loop {
                rest = rest.trim_start();
                if rest.is_empty() || rest.starts_with('#') {
                    break;
                }
                let (mut arg, mut quote, mut escape) = (String::new(), None, false);
                let mut used = rest.len();
                for (i, c) in rest.char_indices() {
                    if escape {
                        escape = false;
                    } else if c == '\\' {
                        escape = true;
                        continue;
                    } else if let Some(q) = quote {
                        if c == q {
                            quote = None;
                            continue;
                        }
                    } else if c == '"' || c == '\'' {
                        quote = Some(c);
                        continue;
                    } else if c == '#' || c.is_whitespace() {
                        used = i;
                        break;
                    }
                    arg.push(c);
                }
                assert!(quote.is_none(), "unmatched quote in {line}");
                out.push(arg);
                rest = &rest[used..];
                if rest.starts_with('#') {
                    break;
                }
            }
        }
        out
    }

    #[test]
    fn sbatch_reads_quoted_values_back_exactly() {
        let dir = "/c/my jobs/it's \"#1\" $(touch decoy); `x` \\";
        let r = Resolved {
            partition: Some("p#1'$(x)".into()),
            ..Resources::default().resolve()
        };
        let s = script_of(&r, "s", Path::new(dir)).expect("no control characters");
        let args = sbatch_args(&s);
        for want in [
            format!("--chdir={dir}"),
            format!("--output={dir}/log/%j.out"),
            "--partition=p#1'$(x)".to_string(),
        ] {
            assert!(args.contains(&want), "{want} in {args:?}\n{s}");
        }
        assert_eq!(sbatch_word("plain/path_1.x"), "plain/path_1.x");
    }

    /// A directory with a fake `modalflow` (it writes its arguments to
    /// `args`) below a name full of shell syntax, where scripts are run.
    #[cfg(unix)]
    struct Sandbox {
        tmp: tempfile::TempDir,
        binary: PathBuf,
    }

    #[cfg(unix)]
    const EVIL: &str = "it's \"q\" $(touch decoy); `touch decoy` \\ $HOME * & | > decoy2 #";

    #[cfg(unix)]
    impl Sandbox {
        fn new() -> Sandbox {
            use std::os::unix::fs::PermissionsExt;
            let tmp = tempfile::tempdir().expect("temp dir");
            let bin_dir = tmp
                .path()
                .join(format!("bin {}", EVIL.replace(['/', '>'], "_")));
            std::fs::create_dir_all(&bin_dir).expect("bin dir");
            let binary = bin_dir.join("modalflow");
            std::fs::write(
                &binary,
                "#!/bin/sh\nprintf '%s\\0' \"$@\" > \"$FAKE_ARGS\"\n",
            )
            .expect("fake binary");
            std::fs::set_permissions(&binary, std::fs::Permissions::from_mode(0o755))
                .expect("chmod");
            Sandbox { tmp, binary }
        }

        fn root(&self) -> &Path {
            self.tmp.path()
        }

        /// `sh -n` parses `text`; running it as array task 1 creates no
        /// decoy anywhere; the fake binary's arguments.
        fn run(&self, text: &str) -> Vec<String> {
            let root = self.root();
            let script = root.join("script.sh");
            std::fs::write(&script, text).expect("script");
            let parse = Command::new("sh")
                .arg("-n")
                .arg(&script)
                .status()
                .expect("sh -n");
            assert!(parse.success(), "sh -n fails on\n{text}");
            let args_file = root.join("args");
            let _ = std::fs::remove_file(&args_file);
            let out = Command::new("sh")
                .arg(&script)
                .current_dir(root)
                .env("SLURM_ARRAY_TASK_ID", "1")
                .env("SLURM_CPUS_PER_TASK", "2")
                .env("TMPDIR", "/node/tmp")
                .env("MF_TEST_X", "$(touch decoy)")
                .env("FAKE_ARGS", &args_file)
                .output()
                .expect("run the script");
            let dirs = std::fs::read_dir(root)
                .expect("sandbox")
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.is_dir())
                .chain([root.to_path_buf()]);
            for dir in dirs {
                for decoy in ["decoy", "decoy2"] {
                    assert!(
                        !dir.join(decoy).exists(),
                        "{decoy} created by\n{text}\n{}",
                        String::from_utf8_lossy(&out.stderr)
                    );
                }
            }
            assert!(
                out.status.success(),
                "{}\n{text}",
                String::from_utf8_lossy(&out.stderr)
            );
            let bytes = std::fs::read(&args_file).expect("the fake binary ran");
            bytes
                .split(|b| *b == 0)
                .filter(|a| !a.is_empty())
                .map(|a| String::from_utf8_lossy(a).into_owned())
                .collect()
        }
    }

    /// Every hostile value the script may carry, in every body: `sh -n`
    /// parses it, running it creates no decoy, and the (fake) binary gets
    /// each value back as one argument.
    #[cfg(unix)]
    #[test]
    fn hostile_names_and_paths_are_inert_in_the_shell() {
        let sandbox = Sandbox::new();
        let root = sandbox.root();
        let cache = root.join(format!("cache\n{EVIL}\ntouch decoy\n"));
        let job_dir = root.join(format!("jobs {}", EVIL.replace('/', "_")));
        let descriptions = [
            cache.join(format!("a\ntouch decoy\n{EVIL}.json")),
            cache.join(format!("b';touch decoy;'{EVIL}.json")),
        ];
        let r = Resolved {
            partition: Some("p;touch$(touch decoy)`touch decoy`'\"#".into()),
            account: Some("a|touch decoy".into()),
            sbatch: vec![
                "--comment=$(touch decoy); `touch decoy` 'x' \"y\" #z".into(),
                "-J x;touch decoy".into(),
            ],
            scratch: Some("$TMPDIR/it's a dir;&|<>*?~!{}[] ${MF_TEST_X}".into()),
            ..Resources::default().resolve()
        };
        let name = format!("s[v=x\ntouch decoy\n{EVIL}\r\u{0}]");
        let bodies = [
            (
                Body::One {
                    description: &descriptions[0],
                    shards: true,
                },
                vec![descriptions[0].clone()],
            ),
            (Body::PerTask(&descriptions), vec![descriptions[1].clone()]),
            (Body::Group(&descriptions), descriptions.to_vec()),
        ];
        for (n, (body, jobs)) in bodies.into_iter().enumerate() {
            let text = Script {
                name: &name,
                dir: &job_dir,
                resources: &r,
                attempt: 1,
                tasks: Some(&[0, 1]),
                binary: &sandbox.binary,
                cache: &cache,
                body,
            }
            .text()
            .expect("every value is quoted");
            let comments: Vec<&str> = text
                .lines()
                .filter(|l| l.starts_with("# modalflow "))
                .collect();
            assert_eq!(comments.len(), 1, "{text}");
            assert!(comments[0].ends_with("(attempt 1)"), "{text}");
            assert!(
                text.lines()
                    .filter(|l| l.starts_with("#SBATCH --job-name="))
                    .all(|l| l["#SBATCH --job-name=".len()..]
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || "._:=,[]-".contains(c))),
                "{text}"
            );
            let args = sandbox.run(&text);
            let mut want: Vec<String> = [
                "exec",
                "--cache",
                cache.to_str().unwrap_or_default(),
                "--scratch",
                "/node/tmp/it's a dir;&|<>*?~!{}[] $(touch decoy)",
            ]
            .map(String::from)
            .to_vec();
            want.extend(jobs.iter().map(|j| j.to_string_lossy().into_owned()));
            if n == 0 {
                want.extend(["--shard".to_string(), "1".to_string()]);
            }
            assert_eq!(args, want, "\n{text}");
            let sbatch = sbatch_args(&text);
            for want in [
                "--partition=p;touch$(touch decoy)`touch decoy`'\"#",
                "--account=a|touch decoy",
                "--comment=$(touch",
            ] {
                assert!(sbatch.iter().any(|a| a == want), "{want} in {sbatch:?}");
            }
        }
    }

    /// Hostile values of every executor field: refused, or inert when the
    /// script runs.
    #[cfg(unix)]
    #[test]
    fn hostile_executor_values_are_refused_or_inert() {
        let sandbox = Sandbox::new();
        let dir = sandbox.root().join("jobs");
        let hostile = [
            INJECT.replace("/tmp/decoy", "decoy"),
            "x\ntouch decoy".into(),
            "$(touch decoy)".into(),
            "`touch decoy`".into(),
            "x;touch decoy".into(),
            "x' ; touch decoy ; '".into(),
            "x\" ; touch decoy ; \"".into(),
            "${X:-$(touch decoy)}".into(),
            "$HOME$(touch decoy)".into(),
            "\\$(touch decoy)".into(),
        ];
        let (mut refused, mut ran) = (0, 0);
        for bad in &hostile {
            let cases: [(&str, &Setter<'_>); 7] = [
                ("partition", &|r| r.partition = Some(bad.clone())),
                ("account", &|r| r.account = Some(bad.clone())),
                ("sbatch", &|r| r.sbatch = vec![bad.clone()]),
                ("sbatch", &|r| r.sbatch = vec![format!("--qos={bad}")]),
                ("time", &|r| r.time = Some(bad.clone())),
                ("memory", &|r| r.memory = bad.clone()),
                ("scratch", &|r| r.scratch = Some(bad.clone())),
            ];
            for (field, set) in cases {
                let mut r = Resources::default().resolve();
                set(&mut r);
                let script = Script {
                    name: bad,
                    dir: &dir,
                    resources: &r,
                    attempt: 1,
                    tasks: None,
                    binary: &sandbox.binary,
                    cache: Path::new("/c"),
                    body: Body::One {
                        description: Path::new("/c/job.json"),
                        shards: false,
                    },
                };
                match script.text() {
                    Err(e) => {
                        let e = e.to_string();
                        assert!(e.contains(&format!("`{field}")), "{field} {bad:?}: {e}");
                        refused += 1;
                    }
                    Ok(text) => {
                        sandbox.run(&text);
                        ran += 1;
                    }
                }
            }
        }
        // Scratch and time/memory with shell syntax are refused; names
        // (partition, account) and `--qos=…` are quoted or sbatch's own.
        assert!(refused > 0 && ran > 0, "{refused} refused, {ran} ran");
    }
}
