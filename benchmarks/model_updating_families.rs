//! The guided identification judged on families (issue 13's acceptance):
//! runs `pipelines/model_updating_families.yaml` (cached: a rerun only
//! rescores) and tabulates, per family of references,
//!
//! - the mean MAC of the updated model against the TRUE modes (every true
//!   mode in the band, paired within ±10 %, an unpaired one counting 0);
//! - the median relative error of the identifiable significant stiffnesses
//!   (significant in the screening, stiffness, and marked identifiable by
//!   the identification's own analysis);
//! - the verdict the identification wrote (cost.json),
//!
//! with success rates against the acceptance thresholds (exact modes:
//! MAC ≥ 0.999 and error < 2 %; AutoEMA modes: MAC ≥ 0.99 and error < 5 %)
//! and the distributions. Writes `results/model_updating_families/summary.md`
//! and `summary.csv`.
//!
//! Run: `cargo bench --bench model_updating_families` (add `-- --score` to
//! rescore existing results without running the pipeline).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use modalflow::metrics::mac;
use modalflow::pairing::{pair_modes, Pairing};
use modalflow::stages::artifacts::read_modes;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const PIPELINE: &str = "pipelines/model_updating_families.yaml";
const RESULTS: &str = "results/model_updating_families";

/// One family: the truth stage, the identify stage and the thresholds.
struct Family {
    name: &'static str,
    truth: fn(u32) -> String,
    identify: fn(u32) -> String,
    seeds: u32,
    min_mac: f64,
    max_error: f64,
}

const FAMILIES: [Family; 3] = [
    Family {
        name: "exact modes",
        truth: |s| format!("truth[s={s}]"),
        identify: |s| format!("exact[s={s}]"),
        seeds: 20,
        min_mac: 0.999,
        max_error: 0.02,
    },
    Family {
        name: "AutoEMA, 1 % noise",
        truth: |s| format!("noisy[s={s}]"),
        identify: |s| format!("measured[measurement=noisy,s={s}]"),
        seeds: 10,
        min_mac: 0.99,
        max_error: 0.05,
    },
    Family {
        name: "AutoEMA, impact test",
        truth: |s| format!("hammer[s={s}]"),
        identify: |s| format!("measured[measurement=hammer,s={s}]"),
        seeds: 10,
        min_mac: 0.99,
        max_error: 0.05,
    },
];

/// The score of one identification.
struct Score {
    seed: u32,
    mean_mac: f64,
    median_error: f64,
    identifiable: usize,
    evaluations: u64,
    ok: bool,
    message: String,
}

fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let headers = r.headers().unwrap().clone();
    r.records()
        .map(|row| {
            let row = row.unwrap();
            headers
                .iter()
                .zip(row.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

fn score(results: &Path, f: &Family, seed: u32, significant: &[String]) -> Score {
    let truth_dir = results.join((f.truth)(seed));
    let id_dir = results.join((f.identify)(seed));
    // MAC against every true mode.
    let truth = read_modes(&truth_dir.join("modes"), "truth").unwrap();
    let updated = read_modes(&id_dir.join("updated_modes"), "updated").unwrap();
    let mut macs = Vec::new();
    for t in &truth {
        let Some(u) = updated
            .iter()
            .find(|u| u.position.index == t.position.index)
        else {
            macs.extend(t.modes.iter().map(|_| 0.0));
            continue;
        };
        let s = t.shared_shapes(u);
        let tf: Vec<f64> = t.modes.iter().map(|m| m.frequency_hz).collect();
        let uf: Vec<f64> = u.modes.iter().map(|m| m.frequency_hz).collect();
        let pairs = pair_modes(&tf, &s.first, &uf, &s.second, &Pairing::within(0.1));
        for k in 0..tf.len() {
            macs.push(
                pairs
                    .iter()
                    .find(|p| p.reference == k)
                    .map_or(0.0, |p| mac(&s.first[k], &s.second[p.candidate])),
            );
        }
    }
    // Errors of the identifiable significant stiffnesses.
    let kinds: BTreeMap<String, (f64, String)> = csv_rows(&truth_dir.join("parameters.csv"))
        .into_iter()
        .map(|r| {
            (
                r["parameter"].clone(),
                (r["value"].parse().unwrap(), r["kind"].clone()),
            )
        })
        .collect();
    let mut errors: Vec<f64> = csv_rows(&id_dir.join("parameters.csv"))
        .into_iter()
        .filter(|r| r["identifiable"] == "true" && significant.contains(&r["parameter"]))
        .filter_map(|r| {
            let (t, kind) = &kinds[&r["parameter"]];
            (kind == "stiffness").then(|| (r["value"].parse::<f64>().unwrap() / t - 1.0).abs())
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    let cost: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(id_dir.join("cost.json")).unwrap()).unwrap();
    Score {
        seed,
        mean_mac: macs.iter().sum::<f64>() / macs.len().max(1) as f64,
        median_error: if errors.is_empty() {
            f64::NAN
        } else {
            errors[errors.len() / 2]
        },
        identifiable: errors.len(),
        evaluations: cost["evaluations"].as_u64().unwrap_or(0),
        ok: cost["verdict"]["ok"].as_bool().unwrap_or(false),
        message: cost["verdict"]["message"]
            .as_str()
            .unwrap_or("")
            .to_string(),
    }
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
    let score_only = std::env::args().any(|a| a == "--score");
    if !score_only {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_modalflow"))
            .args(["run", PIPELINE, "--progress", "lines"])
            .status()
            .expect("run modalflow");
        assert!(status.success(), "the families pipeline failed");
    }
    let results = PathBuf::from(RESULTS);
    let significant: Vec<String> = csv_rows(&results.join("gsa/significant.csv"))
        .into_iter()
        .filter(|r| r["significant"] == "true")
        .map(|r| r["parameter"].clone())
        .collect();
    let mut md =
        String::from("# Guided identification on families (test bench, PUB3 scenario 1)\n\n");
    let mut csv = String::from(
        "family,seed,mean_mac,median_error,identifiable,evaluations,verdict_ok,success\n",
    );
    for f in &FAMILIES {
        let scores: Vec<Score> = (1..=f.seeds)
            .map(|s| score(&results, f, s, &significant))
            .collect();
        let success = |s: &Score| s.mean_mac >= f.min_mac && s.median_error < f.max_error;
        let n_ok = scores.iter().filter(|s| success(s)).count();
        let _ = writeln!(
            md,
            "## {}\n\n{n_ok} of {} reach mean MAC ≥ {} and median identifiable-stiffness error < {} %; verdict ok on {}.\n",
            f.name,
            scores.len(),
            f.min_mac,
            100.0 * f.max_error,
            scores.iter().filter(|s| s.ok).count()
        );
        let macs: Vec<f64> = scores.iter().map(|s| s.mean_mac).collect();
        let errs: Vec<f64> = scores.iter().map(|s| s.median_error).collect();
        let evals: Vec<f64> = scores.iter().map(|s| s.evaluations as f64).collect();
        let _ = writeln!(
            md,
            "| distribution (min / 10 % / median / 90 % / max) | |\n|---|---|"
        );
        let _ = writeln!(md, "| mean MAC vs truth | {} |", quantiles(&macs));
        let _ = writeln!(md, "| median identifiable error | {} |", quantiles(&errs));
        let _ = writeln!(md, "| evaluations | {} |\n", quantiles(&evals));
        let _ = writeln!(md, "| seed | mean MAC | median error | identifiable | evaluations | verdict |\n|---|---|---|---|---|---|");
        for s in &scores {
            let _ = writeln!(
                md,
                "| {} | {:.5} | {:.4} | {} | {} | {}{} |",
                s.seed,
                s.mean_mac,
                s.median_error,
                s.identifiable,
                s.evaluations,
                if s.ok { "ok" } else { "✗ " },
                if s.ok {
                    String::new()
                } else {
                    s.message.clone()
                }
            );
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{},{},{}",
                f.name,
                s.seed,
                s.mean_mac,
                s.median_error,
                s.identifiable,
                s.evaluations,
                s.ok,
                success(s)
            );
        }
        md.push('\n');
    }
    std::fs::write(results.join("summary.md"), &md).unwrap();
    std::fs::write(results.join("summary.csv"), &csv).unwrap();
    println!("{md}");
}
