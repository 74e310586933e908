//! The cost of equal accuracy against the truth (issue 13, PUB4's
//! economics), from AutoEMA modes of noisy FRFs: runs
//! `pipelines/identification_costs.yaml` (cached) and reports, per truth,
//!
//! - the guided strategy's accuracy ([`scoring`]: mean MAC with the true
//!   modes, median identifiable-stiffness error) and its evaluations;
//! - PSO's accuracy at budgets 1,000 – 30,000;
//! - the smallest PSO budget at least as accurate as the guided result on
//!   both measures, and the ratio of evaluations — without the screening
//!   and with it (the GSA runs once per model and is shared by every later
//!   identification; its evaluations solve the same positions).
//!
//! A PSO that never gets there gives a lower bound "> 30,000 / guided".
//! Writes `results/identification_costs/summary.md`.
//!
//! Run: `cargo bench --bench identification_costs` (`-- --score` rescores).

mod scoring;

use scoring::{score, significant};
use std::fmt::Write as _;
use std::path::PathBuf;

const PIPELINE: &str = "pipelines/identification_costs.yaml";
const RESULTS: &str = "results/identification_costs";
const SEEDS: [u32; 3] = [1, 2, 3];
const BUDGETS: [u64; 4] = [1000, 3000, 10000, 30000];

fn main() {
    if !std::env::args().any(|a| a == "--score") {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_modalflow"))
            .args(["run", PIPELINE, "--progress", "lines"])
            .status()
            .expect("run modalflow");
        assert!(status.success(), "the cost pipeline failed");
    }
    let results = PathBuf::from(RESULTS);
    let significant = significant(&results.join("gsa"));
    let gsa: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(results.join("gsa/manifest.json")).expect("gsa manifest"),
    )
    .expect("manifest JSON");
    let gsa_evals = gsa["counters"]["evaluations"].as_u64().unwrap_or(0);
    let mut md = format!(
        "# Evaluations to equal accuracy against the truth (AutoEMA modes, 1 % noise)\n\nScreening (GSA, once per model): {gsa_evals} evaluations.\n\n| truth | guided: MAC / error / evaluations | PSO 1k | PSO 3k | PSO 10k | PSO 30k | PSO needs | ratio | ratio with GSA |\n|---|---|---|---|---|---|---|---|---|\n"
    );
    for s in SEEDS {
        let truth = results.join(format!("truth[s={s}]"));
        let g = score(
            &truth,
            &results.join(format!("guided[s={s}]")),
            &significant,
        );
        let mut cells = Vec::new();
        let mut needed = None;
        for b in BUDGETS {
            let p = score(
                &truth,
                &results.join(format!("pso[s={s},budget={b}]")),
                &significant,
            );
            cells.push(format!("{:.4} / {:.3}", p.mean_mac, p.median_error));
            let as_good = p.mean_mac >= g.mean_mac
                && (p.median_error <= g.median_error || g.median_error.is_nan());
            if as_good && needed.is_none() {
                needed = Some(b);
            }
        }
        let (need, ratio, with_gsa) = match needed {
            Some(b) => (
                b.to_string(),
                format!("{:.1}", b as f64 / g.evaluations as f64),
                format!("{:.2}", b as f64 / (g.evaluations + gsa_evals) as f64),
            ),
            None => {
                let b = BUDGETS[BUDGETS.len() - 1];
                (
                    format!("> {b}"),
                    format!("> {:.1}", b as f64 / g.evaluations as f64),
                    format!("> {:.2}", b as f64 / (g.evaluations + gsa_evals) as f64),
                )
            }
        };
        let _ = writeln!(
            md,
            "| {s} | {:.4} / {:.3} / {} | {} | {need} | {ratio} | {with_gsa} |",
            g.mean_mac,
            g.median_error,
            g.evaluations,
            cells.join(" | ")
        );
    }
    md.push_str("\nCells: mean MAC with the true modes / median error of the identifiable significant stiffnesses.\n");
    std::fs::write(results.join("summary.md"), &md).expect("write summary");
    println!("{md}");
}
