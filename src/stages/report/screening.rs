//! Report sections for a GSA screening (PUB2): the significant/non-significant
//! split of each `gsa` stage, how stable the split is between stages (e.g.
//! two seeds of one study), and the Monte Carlo validation of each split.

use super::read_json;
use crate::report::document::Document;
use crate::stages::StageError;
use std::path::PathBuf;

/// One stage's split read from its `significant.csv`.
struct Split {
    stage: String,
    significant: Vec<String>,
    total: usize,
    /// Parameters whose score interval straddles the threshold (gsa ≥ 8).
    undecided: Vec<String>,
    /// The largest base sample size that decides an undecided parameter,
    /// and whether some undecided parameter has none.
    samples_needed: Option<usize>,
    beyond_reach: bool,
}

fn read_split(stage: &str, path: &PathBuf) -> Result<Split, StageError> {
    let bad = || StageError::InvalidInput {
        input: "splits".into(),
        message: format!(
            "{stage}: expected a significant.csv (parameter,score,…,significant) from a gsa stage"
        ),
    };
    let text = std::fs::read_to_string(path)
        .map_err(|e| StageError::io("cannot read input `splits`", e))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or_else(bad)?.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (Some(c_name), Some(c_sig)) = (col("parameter"), col("significant")) else {
        return Err(bad());
    };
    let (c_undecided, c_needed) = (col("undecided"), col("samples_needed"));
    let mut split = Split {
        stage: stage.to_string(),
        significant: Vec::new(),
        total: 0,
        undecided: Vec::new(),
        samples_needed: None,
        beyond_reach: false,
    };
    for line in lines.filter(|l| !l.trim().is_empty()) {
        split.total += 1;
        let f: Vec<&str> = line.split(',').collect();
        let name = f.get(c_name).copied().unwrap_or_default().to_string();
        if f.get(c_sig) == Some(&"true") {
            split.significant.push(name.clone());
        }
        if c_undecided.and_then(|c| f.get(c)) == Some(&"true") {
            split.undecided.push(name);
            match c_needed
                .and_then(|c| f.get(c))
                .and_then(|n| n.parse::<usize>().ok())
            {
                Some(n) => split.samples_needed = split.samples_needed.max(Some(n)),
                None => split.beyond_reach = true,
            }
        }
    }
    Ok(split)
}

/// "k (names)" of the undecided parameters and the sample size they need.
fn undecided_cells(s: &Split) -> [String; 2] {
    if s.undecided.is_empty() {
        return ["0".into(), "–".into()];
    }
    let needed = match (s.samples_needed, s.beyond_reach) {
        (Some(n), false) => format!("N ≈ {n}"),
        (Some(n), true) => format!("N ≈ {n}; some on the threshold"),
        (None, _) => "on the threshold: no feasible N".into(),
    };
    [
        format!("{} ({})", s.undecided.len(), s.undecided.join(" ")),
        needed,
    ]
}

/// The split of every stage, and the agreement of every pair of splits
/// (Jaccard index of the significant sets, and what differs).
pub fn splits(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let splits = inputs
        .iter()
        .map(|(s, p)| read_split(s, p))
        .collect::<Result<Vec<_>, _>>()?;
    doc.heading(2, "Significant parameters");
    doc.paragraph(
        "Kept: the parameters the split keeps (to be identified). Undecided: parameters whose bootstrap interval of the combined total index straddles the threshold, so this sample size cannot say on which side they lie; the sample size N that would decide them follows from the interval narrowing as 1/√N.",
    );
    doc.table(
        ["stage", "kept", "undecided", "would decide", "parameters"]
            .map(String::from)
            .to_vec(),
        splits
            .iter()
            .map(|s| {
                let [undecided, needed] = undecided_cells(s);
                vec![
                    s.stage.clone(),
                    format!("{} of {}", s.significant.len(), s.total),
                    undecided,
                    needed,
                    s.significant.join(" "),
                ]
            })
            .collect(),
    );
    if splits.len() < 2 {
        return Ok(());
    }
    let mut rows = Vec::new();
    for (i, a) in splits.iter().enumerate() {
        for b in &splits[i + 1..] {
            let common = a
                .significant
                .iter()
                .filter(|p| b.significant.contains(p))
                .count();
            let union = a.significant.len() + b.significant.len() - common;
            let only = |x: &Split, y: &Split| {
                x.significant
                    .iter()
                    .filter(|p| !y.significant.contains(p))
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            rows.push(vec![
                format!("{} / {}", a.stage, b.stage),
                common.to_string(),
                if union == 0 {
                    "–".into()
                } else {
                    format!("{:.3}", common as f64 / union as f64)
                },
                only(a, b),
                only(b, a),
            ]);
        }
    }
    doc.heading(3, "Stability of the split");
    doc.table(
        [
            "pair",
            "in both",
            "Jaccard",
            "only in first",
            "only in second",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    Ok(())
}

/// Min and mean conformity of each validation (PUB2: 89 % and 98.9 %).
pub fn validations(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let rows = inputs
        .iter()
        .map(|(stage, path)| {
            let v = read_json(path, "validations")?;
            let pct = |x: &serde_json::Value| {
                x.as_f64()
                    .map_or("–".into(), |x| format!("{:.2}", 100.0 * x))
            };
            let count = |k: &str| v[k].as_array().map_or(0, Vec::len);
            Ok(vec![
                stage.clone(),
                v["samples"].to_string(),
                format!(
                    "{} of {}",
                    count("random"),
                    count("random") + count("fixed")
                ),
                v["headline"].as_str().unwrap_or("–").to_string(),
                pct(&v["min"]),
                pct(&v["mean"]),
                v["worst"].as_str().unwrap_or("–").to_string(),
            ])
        })
        .collect::<Result<Vec<_>, StageError>>()?;
    doc.heading(2, "Validation of the split");
    doc.paragraph(
        "Significant parameters at their true values, the others drawn at random within their bounds; conformity of every output with the all-true model.",
    );
    doc.table(
        [
            "stage",
            "samples",
            "random parameters",
            "outputs",
            "min conformity %",
            "mean conformity %",
            "worst output",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    Ok(())
}
