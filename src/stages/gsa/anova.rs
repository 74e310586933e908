//! `method: anova` of the `gsa` kind (seed section 2.1.1, PUB1): the ANOVA
//! table of a factorial data set (CSV), or of a full factorial design run on
//! a model with one table per output, the runs as a table and the share of
//! variance per source as a heatmap (outputs × sources: which component's
//! level moves which mode).

use super::spec::{AnovaSource, AnovaSpec};
use super::{build_model, num, write};
use crate::sensitivity::{self, AnovaRow};
use crate::stages::{StageContext, StageError, StageOutputs};
use std::fmt::Write;

pub fn run(ctx: &StageContext, a: &AnovaSpec) -> Result<StageOutputs, StageError> {
    match &a.source {
        AnovaSource::Table {
            data,
            response,
            factors,
        } => run_table(ctx, data, response, factors.as_deref(), a.interactions),
        AnovaSource::Model {
            model,
            levels,
            outputs,
        } => {
            let model = build_model(ctx, model)?;
            let runs: usize = levels.iter().map(|(_, v)| v.len()).product();
            ctx.progress.set_length(runs as u64);
            ctx.progress.set_message(format!("{runs} factorial runs"));
            let r = sensitivity::factorial_anova(
                model.as_ref(),
                levels,
                outputs,
                a.interactions,
                &|k| ctx.progress.inc(k),
            )
            .map_err(|e| match e {
                sensitivity::SensitivityError::Evaluation(e) => StageError::Failed(e.to_string()),
                e => StageError::InvalidParam {
                    param: "levels".into(),
                    message: e.to_string(),
                },
            })?;
            write_factorial(ctx, &r)
        }
    }
}

fn row_text(r: &AnovaRow) -> String {
    let opt = |v: Option<f64>| v.map(num).unwrap_or_default();
    format!(
        "{},{},{},{},{},{}",
        r.source,
        num(r.SS),
        r.DOF,
        num(r.MS),
        opt(r.F),
        opt(r.p)
    )
}

fn run_table(
    ctx: &StageContext,
    data: &str,
    response: &str,
    factors: Option<&[String]>,
    interactions: u8,
) -> Result<StageOutputs, StageError> {
    let path = ctx.pipeline_dir.join(data);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| StageError::io(format!("cannot read `{data}`"), e))?;
    let invalid = |e: sensitivity::SensitivityError| StageError::InvalidParam {
        param: "data".into(),
        message: e.to_string(),
    };
    let design = sensitivity::Design::from_csv(&text, data, response, factors).map_err(invalid)?;
    let rows = sensitivity::anova(&design, interactions).map_err(invalid)?;
    let mut csv = String::from("source,SSB,dof,MS,F,p\n");
    for r in &rows {
        let _ = writeln!(csv, "{}", row_text(r));
    }
    let out = ctx.scratch.join("anova.csv");
    write(&out, &csv)?;
    Ok(StageOutputs {
        files: vec![("anova".into(), out)],
        counters: [("observations".to_string(), design.response.len() as u64)].into(),
    })
}

/// `anova.csv` with a leading `output` column, `runs.csv` (factor values and
/// outputs per run) and `anova.svg` (SS share per output and source).
fn write_factorial(
    ctx: &StageContext,
    r: &sensitivity::FactorialResult,
) -> Result<StageOutputs, StageError> {
    let mut csv = String::from("output,source,SSB,dof,MS,F,p\n");
    for (o, table) in r.outputs.iter().zip(&r.tables) {
        for row in table {
            let _ = writeln!(csv, "{o},{}", row_text(row));
        }
    }
    let anova = ctx.scratch.join("anova.csv");
    write(&anova, &csv)?;

    let mut csv = r.factors.join(",");
    for o in &r.outputs {
        let _ = write!(csv, ",{o}");
    }
    csv.push('\n');
    for (x, y) in r.runs.iter().zip(&r.responses) {
        let cells: Vec<String> = x.iter().chain(y).map(|v| num(*v)).collect();
        let _ = writeln!(csv, "{}", cells.join(","));
    }
    let runs = ctx.scratch.join("runs.csv");
    write(&runs, &csv)?;

    // Share of the total sum of squares per source: 1 for a source that
    // alone explains an output; NaN (blank) for an output that never moved.
    let sources: Vec<String> = r
        .tables
        .first()
        .map(|t| t.iter().map(|row| row.source.clone()).collect())
        .unwrap_or_default();
    let share: Vec<Vec<f64>> = r
        .tables
        .iter()
        .map(|t| {
            let total: f64 = t.iter().map(|row| row.SS).sum();
            t.iter()
                .map(|row| {
                    if total > 0.0 {
                        row.SS / total
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    let svg = crate::report::svg::heatmap(
        &format!("ANOVA: share of variance per source ({})", ctx.stage),
        &r.outputs,
        &sources,
        &share,
        0.0,
        1.0,
    );
    let heatmap = ctx.scratch.join("anova.svg");
    write(&heatmap, &svg)?;
    Ok(StageOutputs {
        files: vec![
            ("anova".into(), anova),
            ("runs".into(), runs),
            ("heatmap".into(), heatmap),
        ],
        counters: [("evaluations".to_string(), r.runs.len() as u64)].into(),
    })
}
