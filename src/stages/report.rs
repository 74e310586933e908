//! The `report` kind: one page per study — a self-contained HTML report
//! (inline SVG) and its Markdown twin — from the artifacts of other stages:
//! `evaluate` metrics (accuracy table), identification costs (evaluations,
//! seconds), convergence histories, parameter errors, and any SVG figures
//! (FRF overlays, MAC matrices, stabilization diagrams, Sobol heatmaps).

mod screening;

use super::{InputSpec, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs};
use crate::report::document::Document;
use crate::report::svg::{bars, Plot, Series, PALETTE};
use serde_json::Value as Json;
use serde_yaml_ng::{Mapping, Value};
use std::path::{Path, PathBuf};

pub struct Report;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "title",
        ty: ParamType::String,
        required: false,
        doc: "page title (default: the pipeline name)",
    },
    ParamSpec {
        name: "description",
        ty: ParamType::String,
        required: false,
        doc: "a paragraph under the title",
    },
];

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "metrics",
        required: false,
        list: true,
        doc: "evaluate metrics (one row each in the accuracy table)",
    },
    InputSpec {
        name: "tables",
        required: false,
        list: true,
        doc: "evaluate tables (parameter errors become a bar chart)",
    },
    InputSpec {
        name: "costs",
        required: false,
        list: true,
        doc: "identification cost.json files (evaluations, seconds)",
    },
    InputSpec {
        name: "histories",
        required: false,
        list: true,
        doc: "history.csv files (evaluation,best_objective[,mean_mac]): convergence curves",
    },
    InputSpec {
        name: "splits",
        required: false,
        list: true,
        doc: "gsa significant.csv files: the split per stage and its stability between stages",
    },
    InputSpec {
        name: "validations",
        required: false,
        list: true,
        doc: "gsa validation.json files: min and mean conformity of each split",
    },
    InputSpec {
        name: "csv",
        required: false,
        list: true,
        doc: "any CSV tables (e.g. anova.csv), shown as they are (first 200 rows)",
    },
    InputSpec {
        name: "figures",
        required: false,
        list: true,
        doc: "SVG files or directories of SVG files to include",
    },
];

impl Stage for Report {
    fn kind(&self) -> &'static str {
        "report"
    }
    fn version(&self) -> u32 {
        2
    }
    fn summary(&self) -> &'static str {
        "an HTML report (self-contained) and a Markdown twin from metrics, costs, histories and figures"
    }
    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    fn outputs(&self, _params: &Mapping) -> Vec<String> {
        vec!["report".into()]
    }

    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let title = ctx
            .params
            .get("title")
            .and_then(Value::as_str)
            .map_or_else(|| format!("{} report", ctx.pipeline), str::to_string);
        let mut doc = Document::new(title);
        if let Some(d) = ctx.params.get("description").and_then(Value::as_str) {
            doc.paragraph(d);
        }
        // Each bound artifact with a label: its stage (one row per stage in
        // the summary tables) or `stage.output` (tables and figures, whose
        // cached files carry hashes, not names).
        let bound = |name: &str, with_output: bool| -> Vec<(String, PathBuf)> {
            let labels = ctx.sources.get(name).cloned().unwrap_or_default();
            let paths = ctx.inputs.get(name).cloned().unwrap_or_default();
            labels
                .into_iter()
                .map(|s| {
                    if with_output {
                        format!("{}.{}", s.stage, s.output)
                    } else {
                        s.stage
                    }
                })
                .zip(paths)
                .collect()
        };
        accuracy(&mut doc, &bound("metrics", false))?;
        costs(&mut doc, &bound("costs", false))?;
        convergence(&mut doc, &bound("histories", false))?;
        parameter_errors(&mut doc, &bound("tables", false))?;
        screening::splits(&mut doc, &bound("splits", false))?;
        screening::validations(&mut doc, &bound("validations", false))?;
        tables(&mut doc, &bound("csv", true))?;
        figures(&mut doc, &bound("figures", true))?;
        let dir = ctx.scratch.join("report");
        let fig_dir = dir.join("figures");
        std::fs::create_dir_all(&fig_dir)
            .map_err(|e| StageError::io("cannot create report directory", e))?;
        let write = |p: PathBuf, text: &str| {
            std::fs::write(&p, text)
                .map_err(|e| StageError::io(format!("cannot write {}", p.display()), e))
        };
        for (file, svg) in doc.figures() {
            write(fig_dir.join(file), svg)?;
        }
        write(dir.join("index.html"), &doc.to_html())?;
        write(dir.join("report.md"), &doc.to_markdown("figures"))?;
        Ok(StageOutputs {
            files: vec![("report".into(), dir)],
            counters: [("figures".to_string(), doc.figures().count() as u64)].into(),
        })
    }
}

pub(super) fn read_json(path: &Path, input: &str) -> Result<Json, StageError> {
    let bytes = std::fs::read(path)
        .map_err(|e| StageError::io(format!("cannot read input `{input}`"), e))?;
    serde_json::from_slice(&bytes).map_err(|e| StageError::InvalidInput {
        input: input.into(),
        message: format!("not JSON: {e}"),
    })
}

fn pct(v: &Json) -> String {
    v.as_f64()
        .filter(|x| x.is_finite())
        .map_or("–".into(), |x| format!("{:.2}", 100.0 * x))
}

fn accuracy(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let mut rows = Vec::new();
    for (stage, path) in inputs {
        let m = read_json(path, "metrics")?;
        rows.push(vec![
            stage.clone(),
            m["modes"]["paired"].as_u64().map_or("–".into(), |p| {
                format!("{p}/{}", m["modes"]["reference_modes"])
            }),
            pct(&m["modes"]["mean_mac"]),
            pct(&m["modes"]["mean_nfd"]),
            pct(&m["modes"]["mean_ndd"]),
            pct(&m["frf"]["mean_frac"]),
            pct(&m["frf"]["mean_csf"]),
            pct(&m["parameters"]["mean_abs_relative_error"]),
        ]);
    }
    doc.heading(2, "Accuracy");
    let header = [
        "stage",
        "paired modes",
        "MAC %",
        "NFD %",
        "NDD %",
        "FRAC %",
        "CSF %",
        "parameter error %",
    ];
    doc.table(header.map(String::from).to_vec(), rows);
    Ok(())
}

fn costs(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let rows = inputs
        .iter()
        .map(|(stage, path)| {
            let c = read_json(path, "costs")?;
            Ok(vec![
                stage.clone(),
                c["evaluations"].to_string(),
                c["seconds"]
                    .as_f64()
                    .map_or("–".into(), |s| format!("{s:.2}")),
                c["best_objective"]
                    .as_f64()
                    .map_or("–".into(), |f| format!("{f:.4e}")),
                c["modes"]["mean_mac"]
                    .as_f64()
                    .map_or("–".into(), |f| format!("{f:.6}")),
            ])
        })
        .collect::<Result<Vec<_>, StageError>>()?;
    doc.heading(2, "Cost");
    doc.table(
        [
            "stage",
            "evaluations",
            "seconds",
            "best objective",
            "mean MAC",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    Ok(())
}

fn convergence(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let mut plot = Plot::new("Convergence", "model evaluations", "best objective");
    plot.y_log = true;
    // 1 − mean MAC of the best point: one scale for criteria that differ
    // between strategies (J for black-box, the refinement's ½‖r‖² for guided).
    let mut mac = Plot::new("MAC reached", "model evaluations", "1 − mean MAC");
    mac.y_log = true;
    for (k, (stage, path)) in inputs.iter().enumerate() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StageError::io("cannot read input `histories`", e))?;
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').map(|f| f.trim().parse().ok()).collect())
            .collect();
        let column = |c: usize| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((*r.first()?, *r.get(c)?)))
                .collect()
        };
        let colour = PALETTE[k % PALETTE.len()];
        plot.series
            .push(Series::line(stage.clone(), column(1), colour));
        let gap: Vec<(f64, f64)> = column(2)
            .into_iter()
            .map(|(e, m)| (e, (1.0 - m).max(1e-12)))
            .collect();
        if !gap.is_empty() {
            mac.series.push(Series::line(stage.clone(), gap, colour));
        }
    }
    doc.heading(2, "Convergence");
    doc.figure(
        "Best objective over model evaluations per optimizer and seed",
        "convergence.svg",
        plot.to_svg(),
    );
    if !mac.series.is_empty() {
        doc.figure(
            "1 − mean MAC of the best point over model evaluations",
            "mac_convergence.svg",
            mac.to_svg(),
        );
    }
    Ok(())
}

fn parameter_errors(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    let mut labels: Vec<String> = Vec::new();
    let mut series = Vec::new();
    for (stage, dir) in inputs {
        let Ok(text) = std::fs::read_to_string(dir.join("parameter_errors.csv")) else {
            continue;
        };
        let mut values = Vec::new();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let (Some(name), Some(rel)) = (f.first(), f.get(3).and_then(|v| v.parse::<f64>().ok()))
            else {
                continue;
            };
            let i = labels.iter().position(|l| l == name).unwrap_or_else(|| {
                labels.push(name.to_string());
                labels.len() - 1
            });
            values.resize(labels.len(), f64::NAN);
            values[i] = 100.0 * rel.abs();
        }
        series.push((stage.clone(), values));
    }
    if series.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Parameter errors");
    doc.figure(
        "Absolute relative error of each identified parameter, %",
        "parameter_errors.svg",
        bars("Parameter errors", "|relative error| %", &labels, &series),
    );
    Ok(())
}

/// CSV inputs as tables, each under its `stage.output` name.
fn tables(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    const MAX_ROWS: usize = 200;
    for (stage, path) in inputs {
        let text = std::fs::read_to_string(path)
            .map_err(|e| StageError::io("cannot read input `csv`", e))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .unwrap_or_default()
            .split(',')
            .map(str::to_string)
            .collect();
        let rows: Vec<Vec<String>> = lines
            .by_ref()
            .take(MAX_ROWS)
            .map(|l| l.split(',').map(short_number).collect())
            .collect();
        doc.heading(2, stage.clone());
        doc.table(header, rows);
        let rest = lines.count();
        if rest > 0 {
            doc.paragraph(format!("{rest} more rows in {stage}."));
        }
    }
    Ok(())
}

/// Numbers to 4 significant digits for reading; text as it is.
fn short_number(cell: &str) -> String {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() && v != v.trunc() => format!("{v:.4e}")
            .parse::<f64>()
            .map_or(cell.to_string(), |r| format!("{r}")),
        _ => cell.to_string(),
    }
}

fn figures(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    doc.heading(2, "Figures");
    for (stage, path) in inputs {
        let mut files: Vec<PathBuf> = if path.is_dir() {
            std::fs::read_dir(path)
                .map_err(|e| StageError::io("cannot read input `figures`", e))?
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "svg"))
                .collect()
        } else {
            vec![path.clone()]
        };
        files.sort();
        for f in files {
            let svg = std::fs::read_to_string(&f)
                .map_err(|e| StageError::io("cannot read input `figures`", e))?;
            if !svg.contains("<svg") {
                return Err(StageError::InvalidInput {
                    input: "figures".into(),
                    message: format!("{} from {stage} is not an SVG", f.display()),
                });
            }
            // A directory's SVGs keep their file names; a single file is
            // named by its output (`stage.output`).
            let name = if path.is_dir() {
                f.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            } else {
                String::new()
            };
            let slug = stage.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
            if name.is_empty() {
                doc.figure(stage.clone(), format!("{slug}.svg"), svg);
            } else {
                doc.figure(format!("{stage}: {name}"), format!("{slug}_{name}"), svg);
            }
        }
    }
    Ok(())
}
