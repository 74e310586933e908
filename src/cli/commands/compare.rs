//! `modalflow compare`: one table of metrics across stages (e.g. the
//! expansions of a matrix), like `dvc exp show`. Every scalar leaf of a
//! stage's `metrics.json`, `cost.json` or `import.json` is a column —
//! numbers, and also text and booleans, so an identification's verdict
//! (`verdict.ok`, `verdict.status`, `verdict.fit`, `verdict.end_rms`) is
//! listed, first after the matrix keys. evaluate and identify files are
//! read through their writers' schemas.

use crate::cli::output::{print_json, print_text, Locations};
use indexmap::IndexMap;
use modalflow::artifacts::cost::Cost;
use modalflow::artifacts::metrics::Metrics;
use modalflow::pipeline::plan::{self, Node};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Tabulate the metrics (`metrics.json`, `cost.json`) of stages across runs:
/// one row per stage with its matrix values, every metric, and an
/// identification's verdict (ok, status, fit, end residual); the messages of
/// failed verdicts are listed under the table.
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Only stages whose name contains this text, or matches it with `*` wildcards
    /// (e.g. `ident[*` or `*seed=2*`).
    pattern: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Print CSV on stdout.
    #[arg(long, conflicts_with = "json")]
    csv: bool,
    #[command(flatten)]
    locations: Locations,
}

/// `--json` output: the pipeline and one row per stage.
#[derive(serde::Serialize)]
#[serde(rename_all = "snake_case")]
struct Table {
    pipeline: String,
    rows: Vec<Row>,
}

/// One stage's row: name, matrix values, metrics (scalar leaves as
/// `a.b.c` paths: numbers, text and booleans).
#[derive(serde::Serialize)]
#[serde(rename_all = "snake_case")]
struct Row {
    stage: String,
    matrix: IndexMap<String, String>,
    metrics: IndexMap<String, Value>,
}

const METRIC_FILES: [&str; 3] = ["metrics.json", "cost.json", "import.json"];

/// Columns shown first, in this order, when present.
const FIRST: [&str; 4] = [
    "verdict.ok",
    "verdict.status",
    "verdict.fit",
    "verdict.end_rms",
];

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

/// Scalar leaves of `v` as `a.b.c` paths: numbers, strings, booleans
/// (arrays are per-position detail and nulls are absent values: skipped).
fn flatten(v: &Value, prefix: &str, out: &mut IndexMap<String, Value>) {
    match v {
        Value::Object(m) => {
            // The schema version describes the file, not the result.
            for (k, x) in m.iter().filter(|(k, _)| k.as_str() != "schema_version") {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(x, &p, out);
            }
        }
        Value::Number(_) | Value::String(_) | Value::Bool(_) => {
            out.insert(prefix.to_string(), v.clone());
        }
        Value::Null | Value::Array(_) => {}
    }
}

/// A metrics file as JSON, through its writer's schema where the stage kind
/// has one.
fn read_metrics(node: &Node, file: &str, path: &Path) -> anyhow::Result<Value> {
    let stale = |e: modalflow::artifacts::ArtifactError| {
        anyhow::anyhow!("{e} (rerun `modalflow run` to refresh the results)")
    };
    Ok(match (node.kind.kind(), file) {
        ("evaluate", "metrics.json") => serde_json::to_value(Metrics::read(path).map_err(stale)?)?,
        ("identify", "cost.json") => serde_json::to_value(Cost::read(path).map_err(stale)?)?,
        _ => serde_json::from_slice(&std::fs::read(path)?)?,
    })
}

/// The rows of every stage matching the pattern that has metrics.
fn collect(plan: &plan::Plan, results: &Path, pattern: Option<&str>) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::new();
    for &i in &plan.order {
        let node = &plan.nodes[i];
        if pattern.is_some_and(|p| !matches(&node.name, p)) {
            continue;
        }
        let mut metrics = IndexMap::new();
        for f in METRIC_FILES {
            let path = results.join(&node.name).join(f);
            if path.is_file() {
                flatten(&read_metrics(node, f, &path)?, "", &mut metrics);
            }
        }
        if metrics.is_empty() {
            continue;
        }
        let matrix = node
            .matrix
            .iter()
            .map(|(k, v)| {
                (
                    k.clone(),
                    modalflow::pipeline::matrix::scalar_text(v).unwrap_or_default(),
                )
            })
            .collect();
        rows.push(Row {
            stage: node.name.clone(),
            matrix,
            metrics,
        });
    }
    Ok(rows)
}

/// Names in order of first appearance over `rows`, [`FIRST`] first.
fn columns<'a>(rows: &'a [Row], of: fn(&'a Row) -> Vec<&'a String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for name in rows.iter().flat_map(of) {
        if !out.contains(name) {
            out.push(name.clone());
        }
    }
    let rank = |c: &String| FIRST.iter().position(|f| f == c).unwrap_or(FIRST.len());
    out.sort_by_key(rank); // stable: the rest keep their order
    out
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(Some(&args.file));
    locations.serve_model_facts();
    let plan = plan::load(&args.file)?;
    let results = locations.results.join(&plan.name);
    let mut rows = collect(&plan, &results, args.pattern.as_deref())?;
    if rows.is_empty() {
        anyhow::bail!("no stage results with metrics under {} (run `modalflow run {}` first, or check the pattern)", results.display(), args.file.display());
    }
    let keys = columns(&rows, |r| r.matrix.keys().collect());
    let cols = columns(&rows, |r| r.metrics.keys().collect());
    for r in &mut rows {
        r.metrics
            .sort_by_cached_key(|k, _| cols.iter().position(|c| c == k));
    }
    if args.json {
        print_json(&Table {
            pipeline: plan.name.clone(),
            rows,
        })?;
    } else if args.csv {
        print_csv(&rows, &keys, &cols)?;
    } else {
        print_table(&rows, &keys, &cols)?;
    }
    Ok(crate::cli::exit::SUCCESS)
}

/// A cell as text: numbers shortened for reading when `short`.
fn text(v: Option<&Value>, short: bool) -> String {
    match v {
        Some(Value::Number(n)) => n.as_f64().map_or_else(
            || n.to_string(),
            |f| if short { fmt(f) } else { f.to_string() },
        ),
        Some(Value::String(s)) => s.clone(),
        Some(Value::Bool(b)) => b.to_string(),
        _ if short => "–".into(),
        _ => String::new(),
    }
}

fn print_csv(rows: &[Row], keys: &[String], cols: &[String]) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<&str> = std::iter::once("stage")
        .chain(keys.iter().map(String::as_str))
        .chain(cols.iter().map(String::as_str))
        .collect();
    w.write_record(&header)?;
    for r in rows {
        let rec: Vec<String> = std::iter::once(r.stage.clone())
            .chain(
                keys.iter()
                    .map(|k| r.matrix.get(k).cloned().unwrap_or_default()),
            )
            .chain(cols.iter().map(|c| text(r.metrics.get(c), false)))
            .collect();
        w.write_record(&rec)?;
    }
    print_text(&String::from_utf8(w.into_inner()?)?)
}

/// The human table; long text (the verdict's message) goes under it, one
/// line per failed verdict.
fn print_table(rows: &[Row], keys: &[String], cols: &[String]) -> anyhow::Result<()> {
    let shown: Vec<&String> = cols.iter().filter(|c| !c.ends_with(".message")).collect();
    let header: Vec<String> = std::iter::once("stage".to_string())
        .chain(keys.iter().cloned())
        .chain(shown.iter().map(|c| c.to_string()))
        .collect();
    let body: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            std::iter::once(r.stage.clone())
                .chain(
                    keys.iter()
                        .map(|k| r.matrix.get(k).cloned().unwrap_or_default()),
                )
                .chain(shown.iter().map(|c| text(r.metrics.get(*c), true)))
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
    for r in rows {
        if r.metrics.get("verdict.ok") == Some(&Value::Bool(false)) {
            let message = text(r.metrics.get("verdict.message"), false);
            out.push_str(&format!("✗ {}: {message}\n", r.stage));
        }
    }
    print_text(&out)
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
    use super::{flatten, matches};
    use indexmap::IndexMap;

    #[test]
    fn patterns() {
        assert!(matches("ident[method=pso,seed=2]", "pso"));
        assert!(matches("ident[method=pso,seed=2]", "ident[*"));
        assert!(matches("ident[method=pso,seed=2]", "*seed=2*"));
        assert!(!matches("ident[method=pso,seed=2]", "*seed=3*"));
        assert!(matches("score", "s*e"));
    }

    #[test]
    fn text_and_boolean_leaves_are_columns_and_arrays_and_nulls_are_not() {
        let v = serde_json::json!({"evaluations": 7, "verdict": {"ok": false, "status": "stalled",
            "end_rms": null, "warnings": ["w"]}, "positions": [{"mean_mac": 1.0}]});
        let mut out = IndexMap::new();
        flatten(&v, "", &mut out);
        let keys: Vec<&str> = out.keys().map(String::as_str).collect();
        assert_eq!(keys, ["evaluations", "verdict.ok", "verdict.status"]);
        assert_eq!(out["verdict.ok"], false);
        assert_eq!(out["verdict.status"], "stalled");
    }
}
