//! `modalflow compare`: one table of metrics across stages (e.g. the
//! expansions of a matrix), like `dvc exp show`.

use crate::cli::output::{print_json, print_text, Locations};
use modalflow::pipeline::plan;
use serde_json::Value;
use std::path::PathBuf;

/// Tabulate the metrics (`metrics.json`, `cost.json`) of stages across runs:
/// one row per stage with its matrix values and every numeric metric.
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Only stages whose name contains this text, or matches it with `*` wildcards
    /// (e.g. `ident[*` or `*seed=2*`).
    pattern: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Print CSV on stdout.
    #[arg(long, conflicts_with = "json")]
    csv: bool,
    #[command(flatten)]
    locations: Locations,
}

/// One stage's row: name, matrix values, numeric metrics.
struct Row {
    stage: String,
    matrix: Vec<(String, String)>,
    metrics: Vec<(String, f64)>,
}

impl Row {
    fn metric(&self, col: &str) -> Option<f64> {
        self.metrics.iter().find(|(c, _)| c == col).map(|(_, v)| *v)
    }

    fn key(&self, k: &str) -> String {
        self.matrix
            .iter()
            .find(|(c, _)| c == k)
            .map_or(String::new(), |(_, v)| v.clone())
    }
}

const METRIC_FILES: [&str; 3] = ["metrics.json", "cost.json", "import.json"];

fn matches(name: &str, pattern: &str) -> bool {
    if !pattern.contains('*') {
        return name.contains(pattern);
    }
    let parts: Vec<&str> = pattern.split('*').collect();
    let mut rest = name;
    for (i, p) in parts.iter().enumerate() {
        if i == 0 {
            let Some(r) = rest.strip_prefix(p) else {
                return false;
            };
            rest = r;
        } else if i == parts.len() - 1 {
            return p.is_empty() || rest.ends_with(p);
        } else {
            let Some(k) = rest.find(p) else { return false };
            rest = &rest[k + p.len()..];
        }
    }
    rest.is_empty()
}

/// Numeric leaves of `v` as `a.b.c` paths (arrays are per-position detail: skipped).
fn flatten(v: &Value, prefix: &str, out: &mut Vec<(String, f64)>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(x, &p, out);
            }
        }
        Value::Number(n) => out.extend(n.as_f64().map(|f| (prefix.to_string(), f))),
        _ => {}
    }
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let plan = plan::load(&args.file)?;
    let results = args.locations.results.join(&plan.name);
    let mut keys: Vec<String> = Vec::new();
    let mut columns: Vec<String> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    for &i in &plan.order {
        let node = &plan.nodes[i];
        if args
            .pattern
            .as_deref()
            .is_some_and(|p| !matches(&node.name, p))
        {
            continue;
        }
        let mut metrics = Vec::new();
        for f in METRIC_FILES {
            let Ok(bytes) = std::fs::read(results.join(&node.name).join(f)) else {
                continue;
            };
            let v: Value = serde_json::from_slice(&bytes)?;
            flatten(&v, "", &mut metrics);
        }
        if metrics.is_empty() {
            continue;
        }
        let matrix: Vec<(String, String)> = node
            .matrix
            .iter()
            .map(|(k, v)| {
                (
                    k.clone(),
                    modalflow::pipeline::matrix::scalar_text(v).unwrap_or_default(),
                )
            })
            .collect();
        for (k, _) in &matrix {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
        for (c, _) in &metrics {
            if !columns.contains(c) {
                columns.push(c.clone());
            }
        }
        rows.push(Row {
            stage: node.name.clone(),
            matrix,
            metrics,
        });
    }
    if rows.is_empty() {
        anyhow::bail!("no stage results with metrics under {} (run `modalflow run {}` first, or check the pattern)", results.display(), args.file.display());
    }
    if args.json {
        let out: Vec<Value> = rows
            .iter()
            .map(|r| {
                let mut m = serde_json::Map::new();
                m.insert("stage".into(), Value::from(r.stage.clone()));
                m.insert(
                    "matrix".into(),
                    r.matrix
                        .iter()
                        .map(|(k, v)| (k.clone(), Value::from(v.clone())))
                        .collect::<serde_json::Map<_, _>>()
                        .into(),
                );
                m.insert(
                    "metrics".into(),
                    r.metrics
                        .iter()
                        .map(|(k, v)| (k.clone(), Value::from(*v)))
                        .collect::<serde_json::Map<_, _>>()
                        .into(),
                );
                Value::Object(m)
            })
            .collect();
        print_json(&serde_json::json!({"pipeline": plan.name, "rows": out}))?;
    } else if args.csv {
        let mut w = csv::Writer::from_writer(Vec::new());
        let header: Vec<&str> = std::iter::once("stage")
            .chain(keys.iter().map(String::as_str))
            .chain(columns.iter().map(String::as_str))
            .collect();
        w.write_record(&header)?;
        for r in &rows {
            let rec: Vec<String> = std::iter::once(r.stage.clone())
                .chain(keys.iter().map(|k| r.key(k)))
                .chain(
                    columns
                        .iter()
                        .map(|c| r.metric(c).map_or(String::new(), |v| v.to_string())),
                )
                .collect();
            w.write_record(&rec)?;
        }
        print_text(&String::from_utf8(w.into_inner()?)?)?;
    } else {
        let header: Vec<String> = std::iter::once("stage".to_string())
            .chain(keys.iter().cloned())
            .chain(columns.iter().cloned())
            .collect();
        let body: Vec<Vec<String>> = rows
            .iter()
            .map(|r| {
                std::iter::once(r.stage.clone())
                    .chain(keys.iter().map(|k| r.key(k)))
                    .chain(columns.iter().map(|c| r.metric(c).map_or("–".into(), fmt)))
                    .collect()
            })
            .collect();
        let widths: Vec<usize> = (0..header.len())
            .map(|j| {
                std::iter::once(&header[j])
                    .chain(body.iter().map(|r| &r[j]))
                    .map(|s| s.chars().count())
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let line = |cells: &[String]| {
            cells
                .iter()
                .zip(&widths)
                .map(|(c, w)| format!("{c:<w$}"))
                .collect::<Vec<_>>()
                .join("  ")
                .trim_end()
                .to_string()
                + "\n"
        };
        let mut out = line(&header);
        for r in &body {
            out.push_str(&line(r));
        }
        print_text(&out)?;
    }
    Ok(crate::cli::exit::SUCCESS)
}

fn fmt(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e9 {
        format!("{v}")
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.4e}")
    } else {
        format!("{v:.5}")
    }
}

#[cfg(test)]
mod tests {
    use super::matches;

    #[test]
    fn patterns() {
        assert!(matches("ident[method=pso,seed=2]", "pso"));
        assert!(matches("ident[method=pso,seed=2]", "ident[*"));
        assert!(matches("ident[method=pso,seed=2]", "*seed=2*"));
        assert!(!matches("ident[method=pso,seed=2]", "*seed=3*"));
        assert!(matches("score", "s*e"));
    }
}
