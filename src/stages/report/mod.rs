//! The `report` kind: one page per study — a self-contained HTML report
//! (inline SVG) and its Markdown twin — from the artifacts of other stages:
//! the identifications' verdicts first (a failed one in red at the top),
//! `evaluate` metrics (accuracy, unpaired and ambiguous modes), costs,
//! identifiability and uncertainty of the identified parameters, the mode
//! correlation of each identification, convergence histories, parameter
//! errors, GSA splits, any CSV table and any SVG figures; and the
//! warnings of every stage upstream of it.
//!
//! JSON inputs are read through their writers' schemas
//! ([`crate::artifacts`]: metrics, cost, identifiability, parameters,
//! correlation, significant).

mod accuracy;
mod charts;
mod correlation;
mod evidence;
pub mod identification;
mod screening;
mod tables;
mod verdicts;
mod warnings;

use super::{Artifact, InputSpec, Kind, StageContext, StageError, StageOutputs};
use crate::artifacts::cost::Cost;
use crate::artifacts::metrics::Metrics;
use crate::report::document::Document;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};

pub struct Report;

crate::params! {
    /// The `report` kind's params.
    pub struct Params {
        /// page title (default: the pipeline name)
        pub title: Option<String> = None,
        /// a paragraph under the title
        pub description: Option<String> = None,
    }
}

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "metrics",
        required: false,
        list: true,
        artifact: Artifact::Metrics,
        doc: "evaluate metrics (one row each in the accuracy table; unpaired and ambiguous modes listed)",
    },
    InputSpec {
        name: "initial",
        required: false,
        list: false,
        artifact: Artifact::Metrics,
        doc: "the metrics of an evaluate of the initial model against the same reference: the first column of the initial-vs-updated comparison",
    },
    InputSpec {
        name: "initial_tables",
        required: false,
        list: false,
        artifact: Artifact::Tables,
        doc: "that evaluate's tables (pairs.csv: the initial model's frequency and MAC per reference mode)",
    },
    InputSpec {
        name: "warnings",
        required: false,
        list: true,
        artifact: Artifact::Json,
        doc: "stage summaries whose warnings the report adds to every upstream stage's own (gsa subproblems: the estimators' notes too); identify verdict warnings come with `costs`",
    },
    InputSpec {
        name: "tables",
        required: false,
        list: true,
        artifact: Artifact::Tables,
        doc: "evaluate tables (parameter errors become a bar chart)",
    },
    InputSpec {
        name: "costs",
        required: false,
        list: true,
        artifact: Artifact::Cost,
        doc: "identify cost.json files: evaluations, seconds and the verdict (a failed one is shown at the top)",
    },
    InputSpec {
        name: "identifiability",
        required: false,
        list: true,
        artifact: Artifact::Identifiability,
        doc: "identify identifiability.json files: the parameter combinations the data do not determine",
    },
    InputSpec {
        name: "parameters",
        required: false,
        list: true,
        artifact: Artifact::Parameters,
        doc: "identify parameters.csv files: identified values with standard errors and 95 % intervals",
    },
    InputSpec {
        name: "correlation",
        required: false,
        list: true,
        artifact: Artifact::Correlation,
        doc: "identify correlation.csv files: which reference mode paired with which model mode, which were excluded and why",
    },
    InputSpec {
        name: "histories",
        required: false,
        list: true,
        artifact: Artifact::History,
        doc: "history.csv files (evaluation,best_objective[,mean_mac]): convergence curves",
    },
    InputSpec {
        name: "splits",
        required: false,
        list: true,
        artifact: Artifact::Significant,
        doc: "gsa significant.csv files: the split per stage and its stability between stages",
    },
    InputSpec {
        name: "validations",
        required: false,
        list: true,
        artifact: Artifact::Validation,
        doc: "gsa validation.json files: min and mean conformity of each split",
    },
    InputSpec {
        name: "csv",
        required: false,
        list: true,
        artifact: Artifact::Table,
        doc: "any CSV tables (e.g. anova.csv), shown as they are (first 200 rows)",
    },
    InputSpec {
        name: "figures",
        required: false,
        list: true,
        artifact: Artifact::Figure,
        doc: "SVG files or directories of SVG files to include",
    },
];

impl Kind for Report {
    type Params = Params;
    const NAME: &'static str = "report";

    /// 3: verdicts, unpaired and ambiguous modes, identifiability and
    /// correlation sections. 4: the run trace's path. 5: the style guide
    /// (captions from the figures, significant digits, p-values), accuracy
    /// per position, each figure as SVG and PNG, zoom of dense figures,
    /// figures/style.txt. 6: the initial-vs-updated comparison (`initial`,
    /// `initial_tables`), every stage's warnings collapsed and counted
    /// (`warnings`), the truth beside identified parameters, complete
    /// convergence curves, large bar charts sorted with the top shown, long
    /// floats in any text to significant digits. 7: the warnings of every
    /// upstream stage (synthesize, autoema, …), bound or not.
    fn version(&self) -> u32 {
        7
    }
    fn reads_upstream_warnings(&self) -> bool {
        true
    }
    fn summary(&self) -> &'static str {
        "an HTML report (self-contained) and a Markdown twin from verdicts, metrics, costs, identifiability, histories and figures"
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[("report", Artifact::Any)];

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let title = p
            .title
            .clone()
            .unwrap_or_else(|| format!("{} report", ctx.pipeline));
        let mut doc = Document::new(title);
        if let Some(d) = &p.description {
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
        let metrics = read_all(&bound("metrics", false), "metrics", Metrics::read)?;
        let costs = read_all(&bound("costs", false), "costs", Cost::read)?;
        let stage_warnings =
            collect_warnings(ctx.upstream_warnings, &costs, &bound("warnings", false))?;
        let initial = match bound("initial", false).first() {
            Some((stage, path)) => {
                Some(Metrics::read(path).map_err(|m| StageError::InvalidInput {
                    input: "initial".into(),
                    message: format!("{stage}: {m}"),
                })?)
            }
            None => None,
        };
        let initial_tables = bound("initial_tables", false).first().map(|b| b.1.clone());
        let tables = bound("tables", false);
        verdicts::summary(&mut doc, &costs, &metrics);
        warnings::summary(&mut doc, &stage_warnings);
        evidence::initial_vs_updated(
            &mut doc,
            initial.as_ref().map(|m| (m, initial_tables.as_ref())),
            &metrics,
            &tables,
        )?;
        accuracy::accuracy(&mut doc, &metrics);
        verdicts::costs(&mut doc, &costs);
        warnings::section(&mut doc, &stage_warnings);
        identification::identifiability(
            &mut doc,
            &bound("identifiability", false),
            &bound("parameters", false),
            &tables,
        )?;
        correlation::correlation(&mut doc, &bound("correlation", false))?;
        let totals = costs
            .iter()
            .map(|(s, c)| (s.clone(), c.evaluations))
            .collect();
        charts::convergence(&mut doc, &bound("histories", false), &totals)?;
        charts::parameter_errors(&mut doc, &tables)?;
        screening::splits(&mut doc, &bound("splits", false))?;
        screening::validations(&mut doc, &bound("validations", false))?;
        tables::tables(&mut doc, &bound("csv", true))?;
        tables::figures(&mut doc, &bound("figures", true))?;
        let warning_total: usize = stage_warnings.iter().map(|(_, w)| w.len()).sum();
        // Relative to `results/<name>/<stage>/report/`; the trace itself
        // changes every run, so only its place enters the cached report.
        doc.paragraph(
            "Run trace (stage, job id and array index, node, state, attempts, elapsed and CPU \
             time, MaxRSS of the last run): ../../trace.csv, or `modalflow show FILE STAGE`.",
        );
        let dir = write_report(&doc, ctx)?;
        Ok(StageOutputs {
            warnings: Vec::new(),
            files: vec![("report".into(), dir)],
            counters: [
                ("figures".to_string(), doc.figures().count() as u64),
                ("warnings".to_string(), warning_total as u64),
            ]
            .into(),
        })
    }
}

/// The warnings of every stage the report reads: every upstream stage's
/// own (run record) warnings in plan order, merged with the
/// identifications' verdict warnings (`costs`) and each bound stage
/// summary's (`warnings`), a warning in both counted once.
fn collect_warnings(
    upstream: &[crate::stages::UpstreamWarnings],
    costs: &[(String, Cost)],
    summaries: &[(String, PathBuf)],
) -> Result<Vec<(String, Vec<String>)>, StageError> {
    let mut out: Vec<(String, Vec<String>)> = upstream
        .iter()
        .map(|u| (u.stage.clone(), u.warnings.clone()))
        .collect();
    for (s, c) in costs {
        warnings::merge(&mut out, s, &c.verdict.warnings);
    }
    for (stage, path) in summaries {
        let w = crate::artifacts::warnings::read(path).map_err(|m| StageError::InvalidInput {
            input: "warnings".into(),
            message: format!("{stage}: {m}"),
        })?;
        warnings::merge(&mut out, stage, &w);
    }
    Ok(out)
}

/// Write the page, its Markdown twin and each figure standalone (SVG and
/// a PNG at 2×, style guide rule 9), with the figure lint's findings (the
/// structure, and fonts and overlaps at the page width) in
/// figures/style.txt; returns the report directory.
fn write_report(doc: &Document, ctx: &StageContext) -> Result<PathBuf, StageError> {
    use crate::report::lint;
    let dir = ctx.scratch.join("report");
    let fig_dir = dir.join("figures");
    std::fs::create_dir_all(&fig_dir)
        .map_err(|e| StageError::io("cannot create report directory", e))?;
    let write = |p: PathBuf, bytes: &[u8]| {
        std::fs::write(&p, bytes)
            .map_err(|e| StageError::io(format!("cannot write {}", p.display()), e))
    };
    let mut problems = Vec::new();
    for (file, svg) in doc.figures() {
        write(fig_dir.join(file), svg.as_bytes())?;
        let stem = file.strip_suffix(".svg").unwrap_or(file);
        let png = crate::report::raster::png(svg, 2.0)
            .map_err(|m| StageError::Failed(format!("cannot render figure {file} as PNG: {m}")))?;
        write(fig_dir.join(format!("{stem}.png")), &png)?;
        let found = lint::check(svg)
            .into_iter()
            .chain(lint::check_rendered(svg, lint::PAGE_WIDTH));
        problems.extend(found.map(|p| format!("{file}: {p}")));
    }
    if !problems.is_empty() {
        ctx.progress.set_message(format!(
            "{} figure problem(s), see figures/style.txt",
            problems.len()
        ));
    }
    write(
        fig_dir.join("style.txt"),
        (problems.join("\n") + "\n").as_bytes(),
    )?;
    write(dir.join("index.html"), doc.to_html().as_bytes())?;
    write(dir.join("report.md"), doc.to_markdown("figures").as_bytes())?;
    Ok(dir)
}

/// Read every bound file of `input` through its schema's reader.
fn read_all<T>(
    inputs: &[(String, PathBuf)],
    input: &str,
    read: fn(&Path) -> Result<T, crate::artifacts::ArtifactError>,
) -> Result<Vec<(String, T)>, StageError> {
    inputs
        .iter()
        .map(|(stage, path)| {
            read(path)
                .map(|v| (stage.clone(), v))
                .map_err(|message| StageError::InvalidInput {
                    input: input.into(),
                    message: format!("{stage}: {message}"),
                })
        })
        .collect()
}

pub(super) fn read_json(path: &Path, input: &str) -> Result<Json, StageError> {
    let bytes = std::fs::read(path)
        .map_err(|e| StageError::io(format!("cannot read input `{input}`"), e))?;
    serde_json::from_slice(&bytes).map_err(|e| StageError::InvalidInput {
        input: input.into(),
        message: format!("not JSON: {e}"),
    })
}

/// A fraction as percent with two decimals; `–` when absent.
fn pct(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or("–".into(), |x| format!("{:.2}", 100.0 * x))
}

/// A number to four significant digits (`0.005685`, `46.51`, `2.406e6`);
/// `–` when absent.
fn sig4(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| crate::report::format::sig(x, 4))
}

#[cfg(test)]
mod tests {
    use super::{pct, sig4};

    #[test]
    fn numbers_read_to_four_digits() {
        assert_eq!(sig4(Some(2_406_012.0)), "2.406e6");
        assert_eq!(sig4(Some(2.0e6)), "2e6");
        assert_eq!(sig4(Some(46.505_1)), "46.51");
        assert_eq!(sig4(Some(0.005_684_9)), "0.005685");
        assert_eq!(sig4(Some(3.953e-5)), "3.953e-5");
        assert_eq!(sig4(Some(0.0)), "0");
        assert_eq!(sig4(Some(f64::INFINITY)), "–");
        assert_eq!(sig4(None), "–");
        assert_eq!(pct(Some(0.123_45)), "12.35");
        assert_eq!(pct(Some(f64::NAN)), "–");
    }
}
