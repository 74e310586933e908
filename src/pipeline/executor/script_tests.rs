//! Tests of `script`, kept apart to keep the module short.
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
        std::fs::set_permissions(&binary, std::fs::Permissions::from_mode(0o755)).expect("chmod");
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
