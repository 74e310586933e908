//! `method: sobol` of the `gsa` kind: Saltelli sampling, evaluation, Sobol
//! indices, the PUB2 screening and its Monte Carlo validation, written as
//! CSV/JSON tables and SVG pictures.

use super::adequacy;
use super::spec::{self, SobolSpec};
use super::{build_model, num, write};
use crate::parameter::nominal;
use crate::sensitivity::{self, sobol};
use crate::simulator::Model;
use crate::stages::{StageContext, StageError, StageOutputs};
use std::fmt::Write;
use std::path::PathBuf;

pub fn run(ctx: &StageContext, s: &SobolSpec) -> Result<StageOutputs, StageError> {
    let model = build_model(ctx, &s.model)?;
    let (report, d) = study(ctx, s, model.as_ref())?;

    let indices = ctx.scratch.join("indices.csv");
    write(&indices, &indices_csv(&report))?;

    let names: Vec<String> = report.outputs.iter().map(|(o, _)| o.clone()).collect();
    let st: Vec<Vec<f64>> = report.outputs.iter().map(|(_, i)| i.ST.clone()).collect();
    let weights = spec::resolve_weights(&names, &s.weights);
    let mut screening = sensitivity::aggregate(
        &report.parameters,
        &names,
        &st,
        &weights,
        s.threshold,
        s.combine,
    )
    .map_err(|e| StageError::Failed(e.to_string()))?;
    let (selection, applied) = adequacy::select(ctx, model.as_ref(), &report, &mut screening, s)?;
    let adequacy = adequacy::intervals(&report, &screening, &weights, applied, s)?;
    // Stage warnings: the estimators' own notes (an output constant over
    // every sample has no indices to rank by), then what the user must know
    // about the split; all of them also in subproblems.json.
    let mut warnings = report.warnings.clone();
    warnings.extend(adequacy::warnings(&adequacy, selection.as_ref()));
    let extra = adequacy::json(&adequacy, selection.as_ref(), applied, &screening);
    let json = subproblems_json(
        s,
        &report,
        &screening,
        extra,
        &warnings,
        &model.named_modes(),
    );
    let subproblems = ctx.scratch.join("subproblems.json");
    let text =
        serde_json::to_string_pretty(&json).map_err(|e| StageError::Failed(e.to_string()))?;
    write(&subproblems, &(text + "\n"))?;

    let heatmap = ctx.scratch.join("sobol.svg");
    write(
        &heatmap,
        &heatmap_svg(ctx.stage, &names, &report.parameters, &st),
    )?;

    // The PUB2 split: parameters ranked by their weighted total index.
    let ranked = adequacy::ranked(&screening);
    let ranking = ctx.scratch.join("ranking.csv");
    write(&ranking, &ranking_csv(&ranked, &screening.significant))?;

    // The split itself, in parameter order, for tools that join on names,
    // with each score's interval and whether N decides it.
    let significant = ctx.scratch.join("significant.csv");
    crate::artifacts::significant::write(
        &significant,
        &adequacy::split_rows(&screening, &adequacy),
    )?;

    let mut files: Vec<(String, PathBuf)> = vec![
        ("indices".into(), indices),
        ("ranking".into(), ranking),
        ("significant".into(), significant),
        ("subproblems".into(), subproblems),
        ("heatmap".into(), heatmap),
    ];
    if s.second_order {
        let path = ctx.scratch.join("second_order.csv");
        write(&path, &second_order_csv(&report, d))?;
        files.push(("second_order".into(), path));
    }
    let mut evaluations = report.evaluations as u64;
    if let Some(sel) = &selection {
        evaluations += sel.evaluations as u64;
    }
    if s.validation > 0 {
        let (v, written) = validate(ctx, model.as_ref(), &screening.significant, s.validation)?;
        files.extend(written);
        evaluations += s.validation as u64 + 1;
        warnings.extend(adequacy::check_validation(
            selection.as_ref(),
            v.min,
            &v.worst,
            v.samples,
        ));
    }
    Ok(StageOutputs {
        warnings,
        files,
        counters: [("evaluations".to_string(), evaluations)].into(),
    })
}

/// Check the names, sample the Saltelli design, evaluate it through the
/// context and analyze every output: the Sobol report and the number of
/// varied parameters.
fn study(
    ctx: &StageContext,
    s: &SobolSpec,
    model: &dyn Model,
) -> Result<(sobol::SobolReport, usize), StageError> {
    let names: Vec<String> = model.parameters().iter().map(|p| p.name.clone()).collect();
    spec::check_names(
        &names,
        model.outputs(),
        &s.outputs,
        &s.parameters,
        &s.weights,
    )
    .map_err(|p| StageError::InvalidParam {
        param: p.path.join("."),
        message: format!("{}; {}", p.message, p.help.unwrap_or_default()),
    })?;
    let params = sobol::SobolParams {
        n: s.samples,
        second_order: s.second_order,
        bootstrap: s.bootstrap,
        confidence: s.confidence,
        seed: ctx.seed,
        subset: s.parameters.clone(),
        outputs: s.outputs.clone(),
        chunk: 256,
    };
    let d = if s.parameters.is_empty() {
        model.parameters().len()
    } else {
        s.parameters.len()
    };
    let layout = sobol::Layout {
        n: s.samples,
        d,
        second_order: s.second_order,
    };
    ctx.progress
        .set_length((layout.len() + s.validation) as u64);
    ctx.progress
        .set_message(format!("{} evaluations", layout.len()));
    // Sharding hook: the design's batch is evaluated through the context
    // (here, as one shard of a job array, or from the shards' partials).
    let evaluate = |xs: &[Vec<f64>]| ctx.evaluate_batch(model, xs, params.chunk);
    let report = sobol::run_with(model, &params, &evaluate)
        .map_err(|e| StageError::Failed(e.to_string()))?;
    Ok((report, d))
}

/// `subproblems.json`: the screening, its split and the per-output
/// subproblems, with the adequacy fields (`extra`) merged in.
fn subproblems_json(
    s: &SobolSpec,
    report: &sobol::SobolReport,
    screening: &sensitivity::Screening,
    extra: serde_json::Map<String, serde_json::Value>,
    warnings: &[String],
    modes: &[(String, f64)],
) -> serde_json::Value {
    let mut json = serde_json::json!({
        "method": "sobol",
        "samples": s.samples,
        "evaluations": report.evaluations,
        "parameters": report.parameters,
        "subproblems": screening.subproblems,
        "significant": screening.significant,
        "non_significant": screening.non_significant,
        "combined_ST": screening.combined_ST.iter().map(|(p, v)| serde_json::json!({"parameter": p, "ST": v})).collect::<Vec<_>>(),
        "weights": screening.weights.iter().map(|(o, w)| serde_json::json!({"output": o, "weight": w})).collect::<Vec<_>>(),
        "threshold": screening.threshold,
        "combine": screening.rule,
        "warnings": warnings,
        "modes": modes.iter().map(|(name, f)| serde_json::json!({"name": name, "frequency_hz": f})).collect::<Vec<_>>(),
    });
    if let Some(map) = json.as_object_mut() {
        map.extend(extra);
    }
    json
}

/// `indices.csv`: S1, ST and their intervals per output and parameter.
fn indices_csv(report: &sobol::SobolReport) -> String {
    let mut csv = String::from("output,parameter,S1,S1_conf,ST,ST_conf\n");
    for (o, idx) in &report.outputs {
        for (i, p) in report.parameters.iter().enumerate() {
            let _ = writeln!(
                csv,
                "{o},{p},{},{},{},{}",
                num(idx.S1[i]),
                num(idx.S1_conf[i]),
                num(idx.ST[i]),
                num(idx.ST_conf[i])
            );
        }
    }
    csv
}

/// `ranking.csv`: parameters by decreasing combined index.
fn ranking_csv(ranked: &[(String, f64)], significant: &[String]) -> String {
    let mut csv = String::from("rank,parameter,score,significant\n");
    for (k, (p, v)) in ranked.iter().enumerate() {
        let _ = writeln!(csv, "{},{p},{},{}", k + 1, num(*v), significant.contains(p));
    }
    csv
}

/// `second_order.csv`: S2 and its interval per output and parameter pair.
fn second_order_csv(report: &sobol::SobolReport, d: usize) -> String {
    let mut csv = String::from("output,parameter_1,parameter_2,S2,S2_conf\n");
    for (o, idx) in &report.outputs {
        if let (Some(s2), Some(c2)) = (&idx.S2, &idx.S2_conf) {
            for i in 0..d {
                for k in i + 1..d {
                    let (pi, pk) = (&report.parameters[i], &report.parameters[k]);
                    let _ = writeln!(csv, "{o},{pi},{pk},{},{}", num(s2[i][k]), num(c2[i][k]));
                }
            }
        }
    }
    csv
}

/// Parameters the ST heatmap shows; the others are one column.
const HEATMAP_PARAMETERS: usize = 24;

/// `sobol.svg`: the ST heatmap, outputs by parameters — the
/// [`HEATMAP_PARAMETERS`] parameters with the largest ST (over the
/// outputs), largest first, and the others as one column of their largest
/// ST per output, so 78 parameters stay readable.
fn heatmap_svg(stage: &str, names: &[String], parameters: &[String], st: &[Vec<f64>]) -> String {
    let top = |j: usize| {
        st.iter()
            .filter_map(|row| row.get(j).copied())
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    };
    let mut order: Vec<usize> = (0..parameters.len()).collect();
    order.sort_by(|&a, &b| top(b).total_cmp(&top(a)));
    let (shown, rest) = order.split_at(order.len().min(HEATMAP_PARAMETERS));
    let mut columns: Vec<String> = shown.iter().map(|&j| parameters[j].clone()).collect();
    if !rest.is_empty() {
        columns.push(format!("other {} (max)", rest.len()));
    }
    let values: Vec<Vec<f64>> = st
        .iter()
        .map(|row| {
            let at = |j: usize| row.get(j).copied().unwrap_or(f64::NAN);
            let mut v: Vec<f64> = shown.iter().map(|&j| at(j)).collect();
            if !rest.is_empty() {
                v.push(
                    rest.iter()
                        .map(|&j| at(j))
                        .filter(|x| x.is_finite())
                        .fold(0.0, f64::max),
                );
            }
            v
        })
        .collect();
    let others = if rest.is_empty() {
        String::new()
    } else {
        format!(
            "; the {} parameters with the largest ST first, the other {} as one column of their largest ST",
            shown.len(),
            rest.len()
        )
    };
    crate::report::svg::heatmap(
        &format!("Total Sobol indices ST ({stage})"),
        ("model output", names),
        ("parameter", &columns),
        &values,
        (0.0, 1.0),
        &format!(
            "Total Sobol indices ST (Jansen) of every model output (rows) to the parameters (columns), {stage}{others}"
        ),
    )
}

/// PUB2's check of the split: `samples` points with the significant
/// parameters at their nominal (true) values and the others random; writes
/// per-output conformity (`validation.csv`), the summary
/// (`validation.json`) and min/mean bars of the headline outputs
/// (`validation.svg`).
fn validate(
    ctx: &StageContext,
    model: &dyn Model,
    significant: &[String],
    samples: usize,
) -> Result<(sensitivity::Validation, Vec<(String, PathBuf)>), StageError> {
    ctx.progress
        .set_message(format!("validation: {samples} evaluations"));
    let x0 = nominal(model.parameters());
    // A stream of its own, so adding validation does not move the Sobol points.
    let seed = ctx.seed ^ 0x5641_4c49_4441_5445;
    let v = sensitivity::validate(model, significant, &x0, samples, seed, &|k| {
        ctx.progress.inc(k)
    })
    .map_err(|e| StageError::Failed(format!("validation: {e}")))?;

    let mut csv = String::from("output,kind,reference,min,mean,p05\n");
    for o in &v.outputs {
        let kind = match o.kind {
            sensitivity::ConformityKind::Criterion => "criterion",
            sensitivity::ConformityKind::Relative => "relative",
        };
        let _ = writeln!(
            csv,
            "{},{kind},{},{},{},{}",
            o.output,
            num(o.reference),
            num(o.min),
            num(o.mean),
            num(o.p05)
        );
    }
    let table = ctx.scratch.join("validation.csv");
    write(&table, &csv)?;

    let summary = ctx.scratch.join("validation.json");
    let text = serde_json::to_string_pretty(&v).map_err(|e| StageError::Failed(e.to_string()))?;
    write(&summary, &(text + "\n"))?;

    let shown: Vec<&sensitivity::OutputConformity> =
        v.outputs.iter().filter(|o| o.kind == v.headline).collect();
    let labels: Vec<String> = shown.iter().map(|o| o.output.clone()).collect();
    let svg = crate::report::svg::bars(
        &format!(
            "Split validation ({samples} samples, {} of {} parameters random): min {:.3}, mean {:.3}",
            v.random.len(),
            v.random.len() + v.fixed.len(),
            v.min,
            v.mean
        ),
        ("model output", &labels),
        "conformity [–]",
        &[
            ("min".into(), shown.iter().map(|o| o.min).collect()),
            ("mean".into(), shown.iter().map(|o| o.mean).collect()),
        ],
        "Minimum and mean conformity of each output over the Monte Carlo samples with the non-significant parameters random (1 = the all-true model's output)",
    );
    let plot = ctx.scratch.join("validation.svg");
    write(&plot, &svg)?;
    let files = vec![
        ("validation".into(), table),
        ("validation_summary".into(), summary),
        ("validation_plot".into(), plot),
    ];
    Ok((v, files))
}

#[cfg(test)]
mod tests {
    use super::{heatmap_svg, HEATMAP_PARAMETERS};

    #[test]
    fn the_heatmap_keeps_the_largest_indices_sorted_and_sums_up_the_rest() {
        let parameters: Vec<String> = (0..78).map(|k| format!("p{k}")).collect();
        let outputs: Vec<String> = (0..6).map(|k| format!("mode{k}.frequency")).collect();
        // ST grows with the parameter's number: p77 matters most.
        let st: Vec<Vec<f64>> = outputs
            .iter()
            .map(|_| (0..78).map(|k| f64::from(k) / 100.0).collect())
            .collect();
        let svg = heatmap_svg("gsa", &outputs, &parameters, &st);
        let columns: Vec<&str> = svg
            .split("transform=\"rotate(-60")
            .skip(1)
            .filter_map(|t| t.split('>').nth(1)?.split('<').next())
            .collect();
        assert_eq!(columns.len(), HEATMAP_PARAMETERS + 1, "{columns:?}");
        assert_eq!(columns[0], "p77");
        assert_eq!(
            columns[HEATMAP_PARAMETERS - 1],
            format!("p{}", 78 - HEATMAP_PARAMETERS)
        );
        assert_eq!(
            columns[HEATMAP_PARAMETERS],
            format!("other {} (max)", 78 - HEATMAP_PARAMETERS)
        );
        // The rest's column holds their largest ST (p53: 0.53).
        assert!(
            svg.contains(&format!("other {} (max): 0.53<", 78 - HEATMAP_PARAMETERS)),
            "{svg}"
        );
        assert!(crate::report::lint::check(&svg).is_empty());
    }
}
