//! Scoring an identify stage against the truth it was made from, shared by
//! the identification benches: the mean MAC of the updated model against
//! every TRUE mode in the band (paired within ±10 %, an unpaired one
//! counting 0), the median relative error of the identifiable significant
//! stiffnesses (significant in the screening, stiffness, and marked
//! identifiable by the identification's own analysis), and its verdict.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use modalflow::metrics::mac;
use modalflow::pairing::{pair_modes, Pairing};
use modalflow::stages::artifacts::read_modes;
use std::collections::BTreeMap;
use std::path::Path;

/// The score of one identification.
pub struct Score {
    pub mean_mac: f64,
    pub median_error: f64,
    pub identifiable: usize,
    pub evaluations: u64,
    pub ok: bool,
    pub message: String,
}

pub fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
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

/// The significant parameters of a gsa stage's results directory.
pub fn significant(gsa: &Path) -> Vec<String> {
    csv_rows(&gsa.join("significant.csv"))
        .into_iter()
        .filter(|r| r["significant"] == "true")
        .map(|r| r["parameter"].clone())
        .collect()
}

/// Score the identify results in `id_dir` against the synthesize results
/// (truth modes and parameters) in `truth_dir`.
pub fn score(truth_dir: &Path, id_dir: &Path, significant: &[String]) -> Score {
    score_model(
        truth_dir,
        &id_dir.join("updated_modes"),
        id_dir,
        "value",
        significant,
    )
}

/// Score the START of the identify stage in `id_dir` (its `initial`
/// values; the modes of the model at them in `start_modes`, e.g. a
/// synthesize stage of the model file) on the same parameters.
pub fn score_start(
    truth_dir: &Path,
    start_modes: &Path,
    id_dir: &Path,
    significant: &[String],
) -> Score {
    score_model(truth_dir, start_modes, id_dir, "initial", significant)
}

fn score_model(
    truth_dir: &Path,
    modes: &Path,
    id_dir: &Path,
    column: &str,
    significant: &[String],
) -> Score {
    let truth = read_modes(&truth_dir.join("modes"), "truth").unwrap();
    let updated = read_modes(modes, "updated").unwrap();
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
            (kind == "stiffness").then(|| (r[column].parse::<f64>().unwrap() / t - 1.0).abs())
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    let cost: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(id_dir.join("cost.json")).unwrap()).unwrap();
    Score {
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
