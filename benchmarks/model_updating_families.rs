//! The guided identification judged on families (issue 13's acceptance):
//! runs `pipelines/model_updating_families.yaml` (cached: a rerun only
//! rescores) and tabulates, per family of references, the score of every
//! identification against its truth ([`scoring`]: mean MAC with the true
//! modes, median identifiable-stiffness error, verdict),
//!
//! with success rates against the acceptance thresholds (exact modes:
//! MAC ≥ 0.999 and error < 2 %; AutoEMA modes: MAC ≥ 0.99 and error < 5 %)
//! and the distributions. Writes `results/model_updating_families/summary.md`
//! and `summary.csv`.
//!
//! Coverage (issue 26): per identification, how many stated 95 % intervals
//! of identified parameters contain the true value; a truth passes when
//! ≥ 90 % do or its verdict is not ok naming implicated parameters, and no
//! ok verdict may have a median error above 5 %.
//!
//! Each success count comes with the 95 % Clopper–Pearson interval of the
//! rate behind it ([`modalflow::binomial`]): 19 of 20 is consistent with
//! 75–99.9 %, so a change that moves a family by one or two truths has not
//! shown that it changes the rate.
//!
//! Run: `cargo bench --bench model_updating_families` (add `-- --score` to
//! rescore existing results without running the pipeline, and
//! `--pipeline FILE` for another machine laid out the same way, e.g.
//! `pipelines/vertical_mill_families.yaml`; its results folder is
//! `results/<name>`).

mod scoring;

use modalflow::binomial::clopper_pearson;
use scoring::{score, score_start, significant, Score};
use std::fmt::Write as _;
use std::path::PathBuf;

const PIPELINE: &str = "pipelines/model_updating_families.yaml";

/// One family: the truth stage, the identify stage and the thresholds.
struct Family {
    name: &'static str,
    truth: fn(u32) -> String,
    identify: fn(u32) -> String,
    seeds: u32,
    min_mac: f64,
    max_error: f64,
    /// The truth moved only parameters the screening kept: a verdict that
    /// blames the screening names the wrong cause.
    in_class: bool,
}

const FAMILIES: [Family; 6] = [
    Family {
        name: "exact modes",
        truth: |s| format!("truth[s={s}]"),
        identify: |s| format!("exact[s={s}]"),
        seeds: 20,
        min_mac: 0.999,
        max_error: 0.02,
        in_class: true,
    },
    // Screened-out parameters moved too, exact modes: judged by coverage
    // and the verdict (no absolute threshold), as the model-error families.
    Family {
        name: "exact modes, every parameter moved (screened-out ones too)",
        truth: |s| format!("truth_all[s={s}]"),
        identify: |s| format!("exact_all[s={s}]"),
        seeds: 20,
        min_mac: f64::NAN,
        max_error: f64::NAN,
        in_class: false,
    },
    Family {
        name: "AutoEMA, 1 % noise",
        truth: |s| format!("noisy[s={s}]"),
        identify: |s| format!("measured[measurement=noisy,s={s}]"),
        seeds: 20,
        min_mac: 0.99,
        max_error: 0.05,
        in_class: true,
    },
    Family {
        name: "AutoEMA, impact test",
        truth: |s| format!("hammer[s={s}]"),
        identify: |s| format!("measured_hammer[s={s}]"),
        seeds: 20,
        min_mac: 0.99,
        max_error: 0.05,
        in_class: true,
    },
    // Model error: success is ending closer to the truth than the start
    // (both measures), judged separately below; no absolute threshold.
    Family {
        name: "machine with every parameter moved (model error), AutoEMA, 1 % noise",
        truth: |s| format!("machine[s={s}]"),
        identify: |s| format!("updated[s={s}]"),
        seeds: 20,
        min_mac: f64::NAN,
        max_error: f64::NAN,
        in_class: false,
    },
    // The same model error measured by impact tests: the per-line noise
    // from coherence (`frf_averages`) must not let it pass.
    Family {
        name: "machine with every parameter moved (model error), AutoEMA, impact test",
        truth: |s| format!("machine_hammer[s={s}]"),
        identify: |s| format!("updated_hammer[s={s}]"),
        seeds: 20,
        min_mac: f64::NAN,
        max_error: f64::NAN,
        in_class: false,
    },
];

/// Issue 26's coverage line: pooled and per truth, and the truths that
/// fail it (below 90 % with an ok verdict or one that names nothing
/// implicated), plus ok verdicts with a median error above 5 %.
fn coverage_text(scores: &[(u32, Score)]) -> String {
    let (n, c) = scores
        .iter()
        .fold((0, 0), |(n, c), (_, s)| (n + s.intervals, c + s.covered));
    let judged = || scores.iter().filter(|(_, s)| s.intervals > 0);
    let below: Vec<&(u32, Score)> = judged()
        .filter(|(_, s)| below_ninety(s.covered, s.intervals))
        .collect();
    let failing: Vec<String> = below
        .iter()
        .filter(|(_, s)| s.ok || !s.names_implicated)
        .map(|(seed, s)| format!("{seed} ({}/{}, {})", s.covered, s.intervals, s.cause))
        .collect();
    let wrong_ok: Vec<String> = scores
        .iter()
        .filter(|(_, s)| s.ok && s.median_error > 0.05)
        .map(|(seed, _)| seed.to_string())
        .collect();
    let expected: f64 = judged()
        .map(|(_, s)| below_ninety_if_exact(s.intervals))
        .sum();
    let (sums, sums_covered) = scores
        .iter()
        .fold((0, 0), |(n, c), (_, s)| (n + s.sums, c + s.sums_covered));
    format!(
        "Coverage: {c} of {n} stated 95 % intervals contain the truth ({:.0} %); {} of {} truths below 90 % (exact 95 % intervals, each covering independently, would leave {expected:.1} on average), of which {} fail (ok, or not naming implicated parameters){}; ok verdicts with median error > 5 %: {}. Sums of structural groups: {sums_covered} of {sums} intervals contain the true sum.",
        100.0 * c as f64 / n.max(1) as f64,
        below.len(),
        scores.len(),
        failing.len(),
        if failing.is_empty() { String::new() } else { format!(": {}", failing.join(", ")) },
        if wrong_ok.is_empty() { "none".to_string() } else { wrong_ok.join(", ") },
    )
}

/// Issue 26's per-truth rule: fewer than 90 % of a truth's `n` intervals
/// cover it.
fn below_ninety(covered: usize, n: usize) -> bool {
    (covered as f64) < 0.9 * n as f64
}

/// The probability that `n` exact, independent 95 % intervals leave a
/// truth [`below_ninety`]: the binomial tail of the misses. It jumps where
/// 10 % of n crosses an integer: 0.21 for 17 intervals, 0.25 for 19 (two
/// misses are too many), 0.075 and 0.085 for 20 and 21 (three are; all
/// checked against scipy's `binom.sf`). So the per-truth rule fails some
/// truths even when the intervals are right; this is the yardstick for
/// that count.
fn below_ninety_if_exact(n: usize) -> f64 {
    // pmf(k) of Binomial(n, 0.05) by the recurrence pmf(k+1) = pmf(k)·(n−k)/(k+1)·p/(1−p).
    let p = 0.05_f64;
    let mut pmf = (1.0 - p).powi(n as i32);
    let mut tail = 0.0;
    for misses in 0..=n {
        if below_ninety(n - misses, n) {
            tail += pmf;
        }
        pmf *= (n - misses) as f64 / (misses + 1) as f64 * p / (1.0 - p);
    }
    tail
}

/// The causes the not-ok verdicts name, counted; for a family whose truth
/// moved only screened-in parameters (`in_class`), the verdicts that blame
/// the screening anyway (`ScreenedOut`: a wrong cause).
fn causes_text(scores: &[(u32, Score)], in_class: bool) -> String {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for (_, s) in scores.iter().filter(|(_, s)| !s.ok) {
        match counts.iter_mut().find(|(c, _)| *c == s.cause) {
            Some((_, n)) => *n += 1,
            None => counts.push((s.cause.clone(), 1)),
        }
    }
    counts.sort();
    let tally: Vec<String> = counts.iter().map(|(c, n)| format!("{c} {n}")).collect();
    let mut text = format!(
        "Causes named by the {} verdicts that are not ok: {}.",
        scores.iter().filter(|(_, s)| !s.ok).count(),
        if tally.is_empty() {
            "none".to_string()
        } else {
            tally.join(", ")
        }
    );
    if in_class {
        let wrong: Vec<String> = scores
            .iter()
            .filter(|(_, s)| s.cause == "ScreenedOut")
            .map(|(seed, _)| seed.to_string())
            .collect();
        let _ = write!(
            text,
            " The truths moved no parameter the screening left fixed; verdicts that blame it anyway: {}.",
            if wrong.is_empty() { "none".to_string() } else { wrong.join(", ") }
        );
    }
    text
}

/// min / 10 % / median / 90 % / max of `v`.
fn quantiles(v: &[f64]) -> String {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return "–".into();
    }
    s.sort_by(f64::total_cmp);
    let q = |p: f64| s[((s.len() - 1) as f64 * p).round() as usize];
    format!(
        "{:.4} / {:.4} / {:.4} / {:.4} / {:.4}",
        q(0.0),
        q(0.1),
        q(0.5),
        q(0.9),
        q(1.0)
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let score_only = args.iter().any(|a| a == "--score");
    let pipeline = args
        .iter()
        .position(|a| a == "--pipeline")
        .and_then(|i| args.get(i + 1))
        .map_or(PIPELINE, String::as_str);
    let text = std::fs::read_to_string(pipeline).expect("read the pipeline file");
    let name = text
        .lines()
        .find_map(|l| l.strip_prefix("name:"))
        .expect("a top-level `name:`")
        .trim();
    let results_dir = format!("results/{name}");
    if !score_only {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_modalflow"))
            .args(["run", pipeline, "--progress", "lines"])
            .status()
            .expect("run modalflow");
        assert!(status.success(), "the families pipeline failed");
    }
    let results = PathBuf::from(&results_dir);
    let significant = significant(&results.join("gsa"));
    let mut md = format!("# Guided identification on families ({pipeline})\n\n");
    // Through the csv crate: the family names hold commas ("AutoEMA, 1 %
    // noise"), which a hand-joined line left unquoted.
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record([
        "family",
        "seed",
        "mean_mac",
        "median_error",
        "identifiable",
        "evaluations",
        "frf_rms",
        "verdict_ok",
        "cause",
        "intervals",
        "covered",
        "success",
    ])
    .unwrap();
    for f in &FAMILIES {
        // With `--score`, seeds whose identification has not run yet are
        // left out (and counted in the heading).
        let seeds: Vec<u32> = (1..=f.seeds)
            .filter(|&s| results.join((f.identify)(s)).join("cost.json").exists())
            .collect();
        if seeds.is_empty() {
            let _ = writeln!(
                md,
                "## {}

not run yet.
",
                f.name
            );
            continue;
        }
        // Per seed: the identification's score and its start's.
        let (scores, starts): (Vec<(u32, Score)>, Vec<Score>) = seeds
            .iter()
            .map(|&s| {
                let truth = results.join((f.truth)(s));
                let id = results.join((f.identify)(s));
                let start = score_start(&truth, &results.join("nominal/modes"), &id, &significant);
                ((s, score(&truth, &id, &significant)), start)
            })
            .unzip();
        let model_error = f.min_mac.is_nan();
        let better = |k: usize, s: &Score| {
            s.mean_mac > starts[k].mean_mac
                && (s.median_error < starts[k].median_error || s.median_error.is_nan())
        };
        let success = |k: usize, s: &Score| {
            if model_error {
                better(k, s) && !s.ok
            } else {
                s.mean_mac >= f.min_mac && s.median_error < f.max_error
            }
        };
        let n_ok = scores
            .iter()
            .enumerate()
            .filter(|(k, (_, s))| success(*k, s))
            .count();
        let goal = if model_error {
            "end closer to the truth than the start (higher MAC with the true modes, lower error) with a verdict that reports the model error".to_string()
        } else {
            format!(
                "reach mean MAC ≥ {} and median identifiable-stiffness error < {} %",
                f.min_mac,
                100.0 * f.max_error
            )
        };
        // What the count says about the rate behind it (issue 26 asks for
        // ≥ 95 %): with 20 truths one or two either way is within it.
        let (low, high) = clopper_pearson(n_ok as u64, scores.len() as u64, 0.95)
            .expect("a family with seeds and at most as many successes");
        let _ = writeln!(
            md,
            "## {}\n\n{n_ok} of {} {goal} (success rate {:.0}–{:.0} %, 95 % Clopper–Pearson interval); verdict ok on {}.\n",
            f.name,
            scores.len(),
            100.0 * low,
            100.0 * high,
            scores.iter().filter(|(_, s)| s.ok).count()
        );
        let _ = writeln!(md, "{}\n", coverage_text(&scores));
        let _ = writeln!(md, "{}\n", causes_text(&scores, f.in_class));
        let macs: Vec<f64> = scores.iter().map(|(_, s)| s.mean_mac).collect();
        let errs: Vec<f64> = scores.iter().map(|(_, s)| s.median_error).collect();
        let evals: Vec<f64> = scores.iter().map(|(_, s)| s.evaluations as f64).collect();
        let _ = writeln!(
            md,
            "| distribution (min / 10 % / median / 90 % / max) | |\n|---|---|"
        );
        let _ = writeln!(md, "| mean MAC vs truth | {} |", quantiles(&macs));
        let _ = writeln!(md, "| median identifiable error | {} |", quantiles(&errs));
        let _ = writeln!(md, "| evaluations | {} |\n", quantiles(&evals));
        let _ = writeln!(md, "| seed | mean MAC (start) | median error (start) | identifiable | evaluations | FRF RMS (σ) | verdict |\n|---|---|---|---|---|---|---|");
        for (k, (seed, s)) in scores.iter().enumerate() {
            let _ = writeln!(
                md,
                "| {} | {:.5} ({:.4}) | {:.4} ({:.3}) | {} | {} | {} | {}{} |",
                seed,
                s.mean_mac,
                starts[k].mean_mac,
                s.median_error,
                starts[k].median_error,
                s.identifiable,
                s.evaluations,
                if s.frf_rms.is_finite() {
                    format!("{:.2}", s.frf_rms)
                } else {
                    "–".into()
                },
                if s.ok { "ok" } else { "✗ " },
                if s.ok {
                    String::new()
                } else {
                    s.message.clone()
                }
            );
            csv.write_record([
                f.name.to_string(),
                seed.to_string(),
                s.mean_mac.to_string(),
                s.median_error.to_string(),
                s.identifiable.to_string(),
                s.evaluations.to_string(),
                s.frf_rms.to_string(),
                s.ok.to_string(),
                s.cause.to_string(),
                s.intervals.to_string(),
                s.covered.to_string(),
                success(k, s).to_string(),
            ])
            .unwrap();
        }
        md.push('\n');
    }
    std::fs::write(results.join("summary.md"), &md).unwrap();
    std::fs::write(results.join("summary.csv"), csv.into_inner().unwrap()).unwrap();
    println!("{md}");
}
