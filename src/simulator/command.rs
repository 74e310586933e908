//! A user's own simulator as a [`Model`]: an external command speaking JSON
//! lines, run with `sh -c` in a given directory.
//!
//! Protocol, one process per batch (or per chunk of `batch` samples):
//! - stdin: one JSON object of parameter values per line, in sample order,
//!   e.g. `{"k1": 1.5e7, "c1": 120.0}`; stdin is closed after the last line.
//! - stdout: one line per sample, in the same order: an object keyed by output
//!   name (`{"f1": 101.2, "f2": 230.5}`), an array in output order
//!   (`[101.2, 230.5]`), or a bare number for a single output. A sample that
//!   cannot be computed answers `{"error": "why"}`; the other samples go on.
//!
//! Failures are reported per sample with its index: a malformed line, a
//! missing output, a process that exits early or non-zero (with the tail of
//! its stderr), or a timeout (the whole process group is killed; samples
//! answered before the timeout keep their results).

use super::{EvalError, Model, Parameter};
use rayon::prelude::*;
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How the external command is run.
#[derive(Clone, Debug)]
pub struct CommandOptions {
    /// Shell command, run as `sh -c COMMAND`.
    pub command: String,
    /// Working directory (the pipeline file's directory in a stage).
    pub dir: PathBuf,
    /// Wall-clock limit for one process (one chunk of samples); `None` waits forever.
    pub timeout: Option<Duration>,
    /// Samples per process; 0 sends the whole batch to one process. Chunks run
    /// in parallel on the rayon pool.
    pub batch: usize,
}

/// An external command as a model.
pub struct CommandModel {
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    options: CommandOptions,
}

impl CommandModel {
    /// Errors when a parameter is invalid, there are no outputs, or names repeat.
    pub fn new(
        parameters: Vec<Parameter>,
        outputs: Vec<String>,
        options: CommandOptions,
    ) -> Result<CommandModel, EvalError> {
        if options.command.trim().is_empty() {
            return Err(EvalError::Command("the model command is empty".into()));
        }
        for p in &parameters {
            p.validate()
                .map_err(|e| EvalError::Command(e.to_string()))?;
        }
        if outputs.is_empty() {
            return Err(EvalError::Command(
                "the command model declares no outputs; list the names its lines contain".into(),
            ));
        }
        let mut names: Vec<&str> = outputs.iter().map(String::as_str).collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(EvalError::Command(format!(
                "output `{}` is listed twice",
                w[0]
            )));
        }
        Ok(CommandModel {
            parameters,
            outputs,
            options,
        })
    }

    fn request(&self, x: &[f64]) -> String {
        let map: serde_json::Map<String, serde_json::Value> = self
            .parameters
            .iter()
            .zip(x)
            .map(|(p, v)| (p.name.clone(), serde_json::json!(v)))
            .collect();
        serde_json::Value::Object(map).to_string()
    }

    /// Parse one answer line.
    fn parse(&self, line: &str) -> Result<Vec<f64>, EvalError> {
        let bad = |m: String| EvalError::Command(format!("{m} in output line `{}`", short(line)));
        let value: serde_json::Value =
            serde_json::from_str(line).map_err(|e| bad(format!("invalid JSON ({e})")))?;
        let number = |v: Option<&serde_json::Value>, name: &str| {
            v.and_then(serde_json::Value::as_f64)
                .ok_or_else(|| bad(format!("output `{name}` is missing or not a number")))
        };
        match &value {
            serde_json::Value::Object(map) => {
                if let Some(e) = map.get("error") {
                    let msg = e.as_str().map_or_else(|| e.to_string(), str::to_string);
                    return Err(EvalError::Domain(format!("the model reported: {msg}")));
                }
                self.outputs
                    .iter()
                    .map(|name| number(map.get(name), name))
                    .collect()
            }
            serde_json::Value::Array(items) if items.len() == self.outputs.len() => self
                .outputs
                .iter()
                .zip(items)
                .map(|(name, v)| number(Some(v), name))
                .collect(),
            serde_json::Value::Array(items) => Err(bad(format!(
                "{} values where {} outputs are declared",
                items.len(),
                self.outputs.len()
            ))),
            serde_json::Value::Number(_) if self.outputs.len() == 1 => {
                Ok(vec![number(Some(&value), &self.outputs[0])?])
            }
            _ => Err(bad("expected an object, an array or a number".into())),
        }
    }

    /// Run one process for `xs`; one result per sample, indices local to `xs`.
    fn run_chunk(&self, xs: &[Vec<f64>]) -> Answers {
        let all = |make: &dyn Fn() -> EvalError| -> Answers {
            (0..xs.len()).map(|i| Err(make().at_sample(i))).collect()
        };
        if let Some(x) = xs.iter().find(|x| x.len() != self.parameters.len()) {
            let (expected, got) = (self.parameters.len(), x.len());
            return all(&|| EvalError::Dimension { expected, got });
        }
        let mut child = match self.spawn_command() {
            Ok(c) => c,
            Err(e) => {
                let kind = e.kind();
                let command = self.options.command.clone();
                return all(&|| EvalError::Spawn {
                    command: command.clone(),
                    source: std::io::Error::from(kind),
                });
            }
        };
        let requests: String = xs.iter().map(|x| self.request(x) + "\n").collect();
        let (lines, stderr_text) = connect_pipes(&mut child, requests);
        let deadline = self.options.timeout.map(|t| Instant::now() + t);
        let (mut results, ended) =
            self.read_answers(xs.len(), &mut child, &lines, &stderr_text, deadline);
        if let Some(e) = ended {
            self.fill_unanswered(&mut results, &e, xs.len());
            return results;
        }
        let status = wait(&mut child, deadline);
        // After the exit the reader sees end-of-file at once; an extra line is a protocol error.
        if lines.recv_timeout(Duration::from_millis(50)).is_ok() {
            let msg = format!(
                "`{}` wrote more lines than the {} samples it was sent; write exactly one line per sample",
                self.options.command,
                xs.len()
            );
            return all(&|| EvalError::Command(msg.clone()));
        }
        if status != "exit status 0" {
            let msg = format!(
                "`{}` answered every sample but failed ({status}){}; results are discarded",
                self.options.command,
                tail(&stderr_text)
            );
            return all(&|| EvalError::Command(msg.clone()));
        }
        results
    }

    /// Start `sh -c COMMAND` in the working directory, in its own process
    /// group (so a timeout can kill all it started), with piped streams.
    fn spawn_command(&self) -> std::io::Result<Child> {
        Command::new("sh")
            .arg("-c")
            .arg(&self.options.command)
            .current_dir(&self.options.dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
    }

    /// Read up to `n` answer lines from `lines` and parse each, until the
    /// `deadline`. Returns the answers read and, when the process timed out
    /// (its group is then killed) or ended before answering all, why.
    fn read_answers(
        &self,
        n: usize,
        child: &mut Child,
        lines: &mpsc::Receiver<String>,
        stderr_text: &mpsc::Receiver<String>,
        deadline: Option<Instant>,
    ) -> (Answers, Option<EvalError>) {
        let mut results = Vec::with_capacity(n);
        let mut ended: Option<EvalError> = None;
        for i in 0..n {
            let line = match deadline {
                Some(d) => lines.recv_timeout(d.saturating_duration_since(Instant::now())),
                None => lines
                    .recv()
                    .map_err(|_| mpsc::RecvTimeoutError::Disconnected),
            };
            match line {
                Ok(line) => results.push(self.parse(&line).map_err(|e| e.at_sample(i))),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    kill_group(child);
                    ended = Some(EvalError::Timeout {
                        seconds: self.options.timeout.map_or(0.0, |t| t.as_secs_f64()),
                    });
                    break;
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    let status = wait(child, deadline);
                    ended = Some(EvalError::Command(format!(
                        "`{}` ended after answering {i} of {} samples ({status}){}",
                        self.options.command,
                        n,
                        tail(stderr_text)
                    )));
                    break;
                }
            }
        }
        (results, ended)
    }

    /// Give every sample the process did not answer before it `ended` (a
    /// timeout or an early end) that error, so `results` has `n` entries.
    fn fill_unanswered(&self, results: &mut Answers, ended: &EvalError, n: usize) {
        let text = ended.to_string();
        let timeout = matches!(ended, EvalError::Timeout { .. });
        let seconds = self.options.timeout.map_or(0.0, |t| t.as_secs_f64());
        for i in results.len()..n {
            let e = if timeout {
                EvalError::Timeout { seconds }
            } else {
                EvalError::Command(text.clone())
            };
            results.push(Err(e.at_sample(i)));
        }
    }
}

/// One result per sample of a chunk.
type Answers = Vec<Result<Vec<f64>, EvalError>>;

/// Feed `requests` to the child's stdin and read its stdout (non-blank
/// lines) and stderr (all of it), each on a detached thread. Returns the
/// receivers of the answer lines and of the stderr text.
fn connect_pipes(
    child: &mut Child,
    requests: String,
) -> (mpsc::Receiver<String>, mpsc::Receiver<String>) {
    // Detached threads: a grandchild that keeps a pipe open must not block us.
    if let Some(mut stdin) = child.stdin.take() {
        std::thread::spawn(move || {
            // A command that stops reading early is reported through its answers.
            let _ = stdin.write_all(requests.as_bytes());
        });
    }
    let (line_tx, lines) = mpsc::channel();
    if let Some(stdout) = child.stdout.take() {
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if line.trim().is_empty() {
                    continue;
                }
                if line_tx.send(line).is_err() {
                    break;
                }
            }
        });
    }
    let (err_tx, stderr_text) = mpsc::channel();
    if let Some(mut stderr) = child.stderr.take() {
        std::thread::spawn(move || {
            let mut text = String::new();
            let _ = stderr.read_to_string(&mut text);
            let _ = err_tx.send(text);
        });
    }
    (lines, stderr_text)
}

impl Model for CommandModel {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        let mut r = self.run_chunk(&[x.to_vec()]);
        match r.pop() {
            Some(Ok(y)) => Ok(y),
            Some(Err(EvalError::Sample { source, .. })) => Err(*source),
            Some(Err(e)) => Err(e),
            None => Err(EvalError::Command("no result".into())),
        }
    }
    fn evaluate_batch(&self, xs: &[Vec<f64>]) -> Vec<Result<Vec<f64>, EvalError>> {
        let size = if self.options.batch == 0 {
            xs.len().max(1)
        } else {
            self.options.batch
        };
        let chunks: Vec<Vec<Result<Vec<f64>, EvalError>>> = xs
            .par_chunks(size)
            .enumerate()
            .map(|(c, chunk)| {
                self.run_chunk(chunk)
                    .into_iter()
                    .map(|r| r.map_err(|e| e.at_sample(c * size)))
                    .collect()
            })
            .collect();
        chunks.into_iter().flatten().collect()
    }
}

/// Kill the command's whole process group (sh and whatever it started).
fn kill_group(child: &mut Child) {
    let group = format!("-{}", child.id());
    let killed = Command::new("kill")
        .args(["-KILL", "--", &group])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !killed {
        let _ = child.kill();
    }
    let _ = child.wait();
}

/// Wait for the exit (until the deadline), describing the status.
fn wait(child: &mut Child, deadline: Option<Instant>) -> String {
    loop {
        match child.try_wait() {
            Ok(Some(s)) => {
                return match s.code() {
                    Some(c) => format!("exit status {c}"),
                    None => "killed by a signal".into(),
                }
            }
            Ok(None) if deadline.is_some_and(|d| Instant::now() >= d) => {
                kill_group(child);
                return "killed after the timeout".into();
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(2)),
            Err(e) => return format!("cannot wait: {e}"),
        }
    }
}

fn tail(stderr: &mpsc::Receiver<String>) -> String {
    let text = stderr
        .recv_timeout(Duration::from_millis(200))
        .unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    if lines.is_empty() {
        return String::new();
    }
    let start = lines.len().saturating_sub(5);
    format!("; stderr ends with: {}", lines[start..].join(" | "))
}

fn short(line: &str) -> String {
    if line.chars().count() <= 80 {
        line.to_string()
    } else {
        format!("{}…", line.chars().take(79).collect::<String>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::{evaluate_all, Scale};

    fn model(script: &str, outputs: &[&str], batch: usize, timeout: Option<f64>) -> CommandModel {
        let params = ["a", "b"]
            .iter()
            .map(|n| Parameter::new(*n, 0.0, 10.0, Scale::Linear).unwrap())
            .collect();
        CommandModel::new(
            params,
            outputs.iter().map(|s| s.to_string()).collect(),
            CommandOptions {
                command: script.into(),
                dir: std::env::temp_dir(),
                timeout: timeout.map(Duration::from_secs_f64),
                batch,
            },
        )
        .unwrap()
    }

    /// sh + awk: reads `{"a":A,"b":B}` and answers a*b + 1 and a - b; the
    /// request text is split on the JSON punctuation.
    const PRODUCT: &str = r#"awk -F'[:,}]' '{ a = $2; b = $4; printf "{\"p\": %.17g, \"d\": %.17g}\n", a * b + 1, a - b }'"#;

    fn points(n: usize) -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| vec![i as f64 * 0.5, 3.0 - i as f64 * 0.25])
            .collect()
    }

    #[test]
    fn awk_model_computes_a_known_function() {
        let xs = points(9);
        for batch in [0, 2, 4] {
            let m = model(PRODUCT, &["p", "d"], batch, Some(20.0));
            let ys = evaluate_all(&m, &xs, 100, &|_| {}).unwrap();
            for (x, y) in xs.iter().zip(&ys) {
                assert_eq!(y, &vec![x[0] * x[1] + 1.0, x[0] - x[1]]);
            }
        }
        let single = model(PRODUCT, &["p", "d"], 0, None);
        assert_eq!(single.evaluate(&[2.0, 4.0]).unwrap(), vec![9.0, -2.0]);
    }

    #[test]
    fn arrays_and_reported_errors_are_per_sample() {
        // Sample 3 (a = 1.5) reports an error; the rest answer arrays.
        let script = r#"awk -F'[:,}]' '{ if ($2 == 1.5) print "{\"error\": \"mesh failed\"}"; else printf "[%.17g]\n", $2 + $4 }'"#;
        let m = model(script, &["s"], 0, Some(20.0));
        let r = m.evaluate_batch(&points(6));
        assert_eq!(r.len(), 6);
        for (i, r) in r.iter().enumerate() {
            if i == 3 {
                let e = r.as_ref().unwrap_err();
                assert_eq!(e.sample_index(), Some(3));
                assert!(e.to_string().contains("mesh failed"), "{e}");
            } else {
                assert!(r.is_ok(), "{i}: {r:?}");
            }
        }
        let err = evaluate_all(&m, &points(6), 100, &|_| {}).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("1 of 6 evaluations failed; first: sample 3"),
            "{err}"
        );
    }

    #[test]
    fn early_exit_names_the_first_unanswered_sample() {
        // Answers two samples, then exits with an error message on stderr.
        let script = r#"awk 'NR <= 2 { print "[1]"; fflush() } NR == 3 { print "diverged" > "/dev/stderr"; exit 3 }'"#;
        let m = model(script, &["y"], 0, Some(20.0));
        let err = evaluate_all(&m, &points(5), 100, &|_| {}).unwrap_err();
        assert_eq!(err.sample_index(), Some(2));
        let text = err.to_string();
        assert!(text.contains("3 of 5"), "{text}");
        assert!(text.contains("answering 2 of 5"), "{text}");
        assert!(
            text.contains("exit status 3") && text.contains("diverged"),
            "{text}"
        );
    }

    #[test]
    fn malformed_lines_and_timeouts_are_reported() {
        let m = model(r#"awk '{ print "{\"y\": \"x\"}" }'"#, &["y"], 0, Some(20.0));
        let e = m.evaluate(&[1.0, 2.0]).unwrap_err();
        assert!(
            e.to_string()
                .contains("output `y` is missing or not a number"),
            "{e}"
        );
        // Two answers, then silence: the timeout fails samples 2.. only.
        let slow = r#"awk 'NR <= 2 { print "[1]"; fflush() } NR == 3 { system("sleep 5") }'"#;
        let m = model(slow, &["y"], 0, Some(0.5));
        let start = Instant::now();
        let r = m.evaluate_batch(&points(4));
        assert!(start.elapsed() < Duration::from_secs(4));
        assert!(r[0].is_ok() && r[1].is_ok());
        let e = r[2].as_ref().unwrap_err();
        assert_eq!(e.sample_index(), Some(2));
        assert!(e.to_string().contains("timeout of 0.5 s"), "{e}");
        let m = model("exit 0", &["y"], 0, None);
        assert!(m
            .evaluate(&[1.0, 1.0])
            .unwrap_err()
            .to_string()
            .contains("answering 0 of 1"));
        let m = model("/nonexistent/simulator", &["y"], 0, None);
        assert!(m.evaluate(&[1.0, 1.0]).is_err());
    }
}
