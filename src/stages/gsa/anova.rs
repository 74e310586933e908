//! `method: anova` of the `gsa` kind (seed section 2.1.1, PUB1): the ANOVA
//! table of a factorial data set (CSV), or of a full factorial design run on
//! a model with one table per output, the runs as a table and the share of
//! variance per source as a heatmap (outputs × sources: which component's
//! level moves which mode); or of the modal models of matrix runs (PUB1:
//! AutoEMA of each BSD × LGS preload state), with the factor levels read
//! from the runs' matrix values and each reference mode tracked by MAC.

use super::spec::{AnovaSource, AnovaSpec};
use super::{build_model, num, write};
use crate::artifacts;
use crate::modal::ModalModel;
use crate::sensitivity::{self, AnovaRow, Design, Factor, FactorialResult};
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
            let text: Vec<Vec<String>> = r
                .runs
                .iter()
                .map(|x| x.iter().map(|v| num(*v)).collect())
                .collect();
            write_factorial(ctx, &r, &text, &[], "evaluations")
        }
        AnovaSource::Modes {
            factors,
            window,
            min_mac,
            outputs,
        } => run_modes(ctx, factors, *window, *min_mac, outputs, a.interactions),
    }
}

/// The responses [`track`] yields, in its order: frequency and damping of
/// each reference mode, `p{position}.mode{r}.frequency|damping`.
fn tracked_outputs(reference: &[ModalModel]) -> Vec<String> {
    let mut names = Vec::new();
    for r in reference {
        for m in 1..=r.modes.len() {
            let pos = r.position.index;
            names.push(format!("p{pos}.mode{m}.frequency"));
            names.push(format!("p{pos}.mode{m}.damping"));
        }
    }
    names
}

/// Frequency and damping of every reference mode in one run, `None` where
/// no mode of the run pairs with it (MAC on shared DOFs, Hungarian pairing
/// within the window, eq. 2.62/2.64).
fn track(
    reference: &[ModalModel],
    run: &[ModalModel],
    window: f64,
    min_mac: f64,
) -> Vec<Option<f64>> {
    let mut values = Vec::new();
    for r in reference {
        let c = run.iter().find(|c| c.position.index == r.position.index);
        let mut partner = vec![None; r.modes.len()];
        if let Some(c) = c {
            let shared = r.shared_shapes(c);
            if !shared.dofs.is_empty() {
                let rf: Vec<f64> = r.modes.iter().map(|m| m.frequency_hz).collect();
                let cf: Vec<f64> = c.modes.iter().map(|m| m.frequency_hz).collect();
                let settings = crate::pairing::Pairing {
                    window,
                    min_mac,
                    ..Default::default()
                };
                let pairs =
                    crate::pairing::pair_modes(&rf, &shared.first, &cf, &shared.second, &settings);
                for p in pairs {
                    partner[p.reference] = Some(&c.modes[p.candidate]);
                }
            }
        }
        for p in partner {
            values.push(p.map(|p| p.frequency_hz));
            values.push(p.map(|p| p.damping_ratio));
        }
    }
    values
}

/// ANOVA of the modal models of matrix runs (PUB1): every reference mode
/// tracked through the runs bound to `modes`, its frequency and damping
/// analysed over the factors' levels read from the runs' matrix values.
fn run_modes(
    ctx: &StageContext,
    factors: &[String],
    window: f64,
    min_mac: f64,
    selected: &[String],
    interactions: u8,
) -> Result<StageOutputs, StageError> {
    let reference = artifacts::modes::read_modes(ctx.input("reference")?, "reference")?;
    let paths = ctx.inputs.get("modes").cloned().unwrap_or_default();
    let levels = run_levels(ctx, factors)?;

    let table: Vec<Vec<Option<f64>>> = paths
        .iter()
        .map(|path| {
            artifacts::modes::read_modes(path, "modes")
                .map(|run| track(&reference, &run, window, min_mac))
        })
        .collect::<Result<_, _>>()?;
    let names = tracked_outputs(&reference);
    let chosen =
        sensitivity::select_outputs(&names, selected).map_err(|e| StageError::InvalidParam {
            param: "outputs".into(),
            message: e.to_string(),
        })?;
    let (result, skipped) = output_tables(&table, &names, chosen, &levels, interactions)?;
    let text: Vec<Vec<String>> = (0..table.len())
        .map(|j| levels.labels.iter().map(|l| l[j].clone()).collect())
        .collect();
    write_factorial(ctx, &result, &text, &skipped, "runs")
}

/// A problem with the runs bound to `modes`.
fn invalid_modes(message: String) -> StageError {
    StageError::InvalidInput {
        input: "modes".into(),
        message,
    }
}

/// The factors of matrix runs and each run's level of each, as the matrix
/// values are written (`labels[factor][run]`).
struct RunLevels {
    factors: Vec<String>,
    labels: Vec<Vec<String>>,
}

/// The levels of `factors` (none given: every matrix key that varies) in
/// each run bound to `modes`, read from the runs' matrix values.
fn run_levels(ctx: &StageContext, factors: &[String]) -> Result<RunLevels, StageError> {
    let sources = ctx.sources.get("modes").cloned().unwrap_or_default();
    // Matrix values of every run, keys in the order of the first run.
    let runs: Vec<Vec<(String, String)>> = sources.iter().map(|s| s.matrix_text()).collect();
    let keys: Vec<String> = runs
        .first()
        .map(|r| r.iter().map(|(k, _)| k.clone()).collect())
        .unwrap_or_default();
    let level = |run: &[(String, String)], key: &str| {
        run.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
    };
    let factors: Vec<String> = if factors.is_empty() {
        keys.iter()
            .filter(|k| {
                let first = level(&runs[0], k);
                runs.iter().any(|r| level(r, k) != first)
            })
            .cloned()
            .collect()
    } else {
        factors.to_vec()
    };
    if factors.is_empty() {
        return Err(invalid_modes(format!(
            "the {} bound runs have no matrix key that varies ({}); bind the modes of a matrix stage such as `ema[*].modes`",
            runs.len(),
            sources.iter().map(|s| s.stage.as_str()).collect::<Vec<_>>().join(", ")
        )));
    }
    let mut labels: Vec<Vec<String>> = vec![Vec::new(); factors.len()];
    for (run, source) in runs.iter().zip(&sources) {
        for (f, name) in factors.iter().enumerate() {
            let v = level(run, name).ok_or_else(|| {
                invalid_modes(format!(
                    "run `{}` has no matrix key `{name}`; its keys: {}",
                    source.stage,
                    keys.join(", ")
                ))
            })?;
            labels[f].push(v);
        }
    }
    Ok(RunLevels { factors, labels })
}

/// The ANOVA table of each `chosen` output of the tracking `table` (runs ×
/// outputs) over the design of `levels`, and the outputs left out because
/// some run has no partner for them.
fn output_tables(
    table: &[Vec<Option<f64>>],
    names: &[String],
    chosen: Vec<usize>,
    levels: &RunLevels,
    interactions: u8,
) -> Result<(FactorialResult, Vec<String>), StageError> {
    let factors = &levels.factors;
    let design_factors: Vec<Factor> = factors
        .iter()
        .zip(&levels.labels)
        .map(|(n, l)| Factor::from_labels(n.clone(), l))
        .collect();
    let mut result = FactorialResult {
        factors: factors.clone(),
        runs: Vec::new(), // levels may be text; written from `labels`
        outputs: Vec::new(),
        responses: vec![Vec::new(); table.len()],
        tables: Vec::new(),
    };
    let mut skipped = Vec::new();
    for o in chosen {
        let name = &names[o];
        let column: Option<Vec<f64>> = table.iter().map(|row| row[o]).collect();
        let Some(column) = column else {
            let missing = table.iter().filter(|row| row[o].is_none()).count();
            skipped.push(format!(
                "{name}: unpaired in {missing} of {} runs",
                table.len()
            ));
            continue;
        };
        let design = Design {
            factors: design_factors.clone(),
            response: column.clone(),
        };
        let rows = sensitivity::anova(&design, interactions)
            .map_err(|e| invalid_modes(format!("output `{name}`: {e}")))?;
        for (r, v) in result.responses.iter_mut().zip(&column) {
            r.push(*v);
        }
        result.outputs.push(name.clone());
        result.tables.push(rows);
    }
    if result.outputs.is_empty() {
        return Err(invalid_modes(format!(
            "no reference mode pairs in every run ({}); widen `window` or lower `min_mac`",
            skipped.join("; ")
        )));
    }
    Ok((result, skipped))
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
        warnings: Vec::new(),
        files: vec![("anova".into(), out)],
        counters: [("observations".to_string(), design.response.len() as u64)].into(),
    })
}

/// `anova.csv` with a leading `output` column, `runs.csv` (factor values and
/// outputs per run) and `anova.svg` (SS share per output and source).
fn write_factorial(
    ctx: &StageContext,
    r: &FactorialResult,
    levels: &[Vec<String>],
    skipped: &[String],
    counter: &str,
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
    for (x, y) in levels.iter().zip(&r.responses) {
        let cells: Vec<String> = x.iter().cloned().chain(y.iter().map(|v| num(*v))).collect();
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
    let title = if skipped.is_empty() {
        format!("ANOVA: share of variance per source ({})", ctx.stage)
    } else {
        format!(
            "ANOVA: share of variance per source ({}; {} outputs left out: not paired in every run)",
            ctx.stage,
            skipped.len()
        )
    };
    let svg = crate::report::svg::heatmap(
        &title,
        ("model output", &r.outputs),
        ("source of variance", &sources),
        &share,
        (0.0, 1.0),
        "Share of each output's variance (sum of squares) explained by each factor, interaction and the residual (ANOVA, section 2.1.1)",
    );
    let heatmap = ctx.scratch.join("anova.svg");
    write(&heatmap, &svg)?;
    Ok(StageOutputs {
        warnings: Vec::new(),
        files: vec![
            ("anova".into(), anova),
            ("runs".into(), runs),
            ("heatmap".into(), heatmap),
        ],
        counters: [
            (counter.to_string(), levels.len() as u64),
            ("outputs_left_out".to_string(), skipped.len() as u64),
        ]
        .into(),
    })
}
