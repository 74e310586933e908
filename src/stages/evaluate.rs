//! The `evaluate` kind: how well a candidate (identified or updated) model
//! matches a reference, by the criteria of seed section 2.3.4 — MAC matrix,
//! MACXP, NFD, NDD of paired modes (eq. 2.62–2.65), FRAC and CSF of FRFs
//! (eq. 2.66–2.67) — and, when the truth is known, parameter errors.
//!
//! Modes are paired per position by an optimal MAC assignment within a
//! relative frequency window ([`crate::metrics::pair_modes`]), on the DOFs
//! both models share.

use super::artifacts::{read_frf, read_modes};
use super::{
    InputSpec, ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs,
};
use crate::frf::FrfSet;
use crate::metrics;
use crate::modal::ModalModel;
use crate::report::svg::{heatmap, Plot, Series, PALETTE};
use num_complex::Complex64;
use serde_json::json;
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

pub struct Evaluate;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "window",
        ty: ParamType::Number,
        required: false,
        doc: "relative frequency window for pairing modes (default 0.2 = ±20 %)",
    },
    ParamSpec {
        name: "min_mac",
        ty: ParamType::Number,
        required: false,
        doc: "minimum MAC of a pair (default 0.3)",
    },
];

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "reference",
        required: false,
        list: false,
        doc: "reference modes (e.g. synthesize.modes)",
    },
    InputSpec {
        name: "candidate",
        required: false,
        list: false,
        doc: "candidate modes (e.g. autoema.modes)",
    },
    InputSpec {
        name: "reference_frf",
        required: false,
        list: false,
        doc: "reference FRFs",
    },
    InputSpec {
        name: "candidate_frf",
        required: false,
        list: false,
        doc: "candidate FRFs on the same lines (e.g. autoema.frf_fit)",
    },
    InputSpec {
        name: "initial_frf",
        required: false,
        list: false,
        doc: "FRFs before updating (e.g. a synthesize stage at the start values): a third curve in the overlays and their FRAC/CSF as `initial_mean_frac`/`initial_mean_csf`",
    },
    InputSpec {
        name: "truth",
        required: false,
        list: false,
        doc: "true parameters (synthesize.truth)",
    },
    InputSpec {
        name: "estimate",
        required: false,
        list: false,
        doc: "estimated parameters (parameters.csv)",
    },
];

fn number(params: &Mapping, key: &str, default: f64) -> f64 {
    params.get(key).and_then(Value::as_f64).unwrap_or(default)
}

impl Stage for Evaluate {
    fn kind(&self) -> &'static str {
        "evaluate"
    }
    /// 2: modes paired by frequency and MAC.
    fn version(&self) -> u32 {
        2
    }
    fn summary(&self) -> &'static str {
        "compare candidate modes/FRFs/parameters with a reference: MAC, MACXP, NFD, NDD, FRAC, CSF, parameter errors"
    }
    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    fn outputs(&self, _params: &Mapping) -> Vec<String> {
        ["metrics", "tables", "plots"].map(String::from).to_vec()
    }
    fn check(&self, params: &Mapping) -> Result<(), ParamProblem> {
        let w = number(params, "window", 0.2);
        if w.is_nan() || w <= 0.0 {
            return Err(ParamProblem {
                path: vec!["window".into()],
                message: format!("window {w} must be > 0"),
                help: Some("a relative frequency difference, e.g. 0.2".into()),
            });
        }
        let m = number(params, "min_mac", 0.3);
        if !(0.0..=1.0).contains(&m) {
            return Err(ParamProblem {
                path: vec!["min_mac".into()],
                message: format!("min_mac {m} must be in [0, 1]"),
                help: None,
            });
        }
        Ok(())
    }

    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let has = |n: &str| ctx.inputs.contains_key(n);
        let pairs_ok = (has("reference") && has("candidate"))
            || (has("reference_frf") && has("candidate_frf"))
            || (has("truth") && has("estimate"));
        if !pairs_ok {
            return Err(StageError::Failed("nothing to compare: bind reference+candidate, reference_frf+candidate_frf, or truth+estimate".into()));
        }
        let tables = ctx.scratch.join("tables");
        let plots = ctx.scratch.join("plots");
        for d in [&tables, &plots] {
            std::fs::create_dir_all(d)
                .map_err(|e| StageError::io("cannot create output directory", e))?;
        }
        let mut summary = serde_json::Map::new();
        if has("reference") && has("candidate") {
            let reference = read_modes(ctx.input("reference")?, "reference")?;
            let candidate = read_modes(ctx.input("candidate")?, "candidate")?;
            let modal = compare_modes(
                &reference,
                &candidate,
                number(ctx.params, "window", 0.2),
                number(ctx.params, "min_mac", 0.3),
                &tables,
                &plots,
            )?;
            summary.insert("modes".into(), modal);
        }
        if has("reference_frf") && has("candidate_frf") {
            let r = read_frf(ctx.input("reference_frf")?, "reference_frf")?;
            let c = read_frf(ctx.input("candidate_frf")?, "candidate_frf")?;
            let initial = if has("initial_frf") {
                Some(read_frf(ctx.input("initial_frf")?, "initial_frf")?)
            } else {
                None
            };
            summary.insert(
                "frf".into(),
                compare_frfs(&r, &c, initial.as_deref(), &tables, &plots)?,
            );
        }
        if has("truth") && has("estimate") {
            let t = read_parameters(ctx.input("truth")?, "truth")?;
            let e = read_parameters(ctx.input("estimate")?, "estimate")?;
            summary.insert("parameters".into(), compare_parameters(&t, &e, &tables)?);
        }
        let path = ctx.scratch.join("metrics.json");
        std::fs::write(
            &path,
            serde_json::to_vec_pretty(&summary).unwrap_or_default(),
        )
        .map_err(|e| StageError::io("cannot write metrics.json", e))?;
        Ok(StageOutputs {
            files: vec![
                ("metrics".into(), path),
                ("tables".into(), tables),
                ("plots".into(), plots),
            ],
            counters: Default::default(),
        })
    }
}

fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

fn compare_modes(
    reference: &[ModalModel],
    candidate: &[ModalModel],
    window: f64,
    min_mac: f64,
    tables: &Path,
    plots: &Path,
) -> Result<serde_json::Value, StageError> {
    let mut pairs_csv = String::from("position,reference_mode,candidate_mode,reference_hz,candidate_hz,NFD,reference_damping,candidate_damping,NDD,MAC,MACXP\n");
    let mut mac_csv = String::from("position,reference_mode,candidate_mode,MAC\n");
    let mut positions = Vec::new();
    let (mut all_mac, mut all_nfd, mut all_ndd) = (Vec::new(), Vec::new(), Vec::new());
    for r in reference {
        let Some(c) = candidate
            .iter()
            .find(|c| c.position.index == r.position.index)
        else {
            positions.push(json!({"position": r.position.index, "label": r.position.label, "error": "no candidate modes for this position"}));
            continue;
        };
        let shared = r.shared_shapes(c);
        let (rs, cs, dofs) = (shared.first, shared.second, shared.dofs);
        if dofs.is_empty() {
            return Err(StageError::InvalidInput {
                input: "candidate".into(),
                message: format!(
                    "position {}: no DOF in common with the reference",
                    r.position.index
                ),
            });
        }
        let rf: Vec<f64> = r.modes.iter().map(|m| m.frequency_hz).collect();
        let cf: Vec<f64> = c.modes.iter().map(|m| m.frequency_hz).collect();
        let macs = metrics::mac_matrix(&rs, &cs);
        for (i, row) in macs.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let _ = writeln!(mac_csv, "{},{},{},{v}", r.position.index, i + 1, j + 1);
            }
        }
        let labels = |f: &[f64]| {
            f.iter()
                .enumerate()
                .map(|(k, f)| format!("{} ({f:.1} Hz)", k + 1))
                .collect::<Vec<_>>()
        };
        let svg = heatmap(
            &format!("MAC, position {} {}", r.position.index, r.position.label),
            &labels(&rf),
            &labels(&cf),
            &macs,
            0.0,
            1.0,
        );
        write(&plots.join(format!("mac_{}.svg", r.position.index)), &svg)?;
        let settings = crate::pairing::Pairing {
            window,
            min_mac,
            ..Default::default()
        };
        let pairs = crate::pairing::pair_modes(&rf, &rs, &cf, &cs, &settings);
        let (mut macs_p, mut nfds, mut ndds) = (Vec::new(), Vec::new(), Vec::new());
        for p in &pairs {
            let (a, b) = (&r.modes[p.reference], &c.modes[p.candidate]);
            let nfd = metrics::nfd(a.frequency_hz, b.frequency_hz);
            let ndd = metrics::ndd(a.damping_ratio, b.damping_ratio);
            let xp = metrics::macxp(
                &rs[p.reference],
                &cs[p.candidate],
                metrics::pole(a.frequency_hz, a.damping_ratio),
                metrics::pole(b.frequency_hz, b.damping_ratio),
            );
            let _ = writeln!(
                pairs_csv,
                "{},{},{},{},{},{nfd},{},{},{ndd},{},{xp}",
                r.position.index,
                p.reference + 1,
                p.candidate + 1,
                a.frequency_hz,
                b.frequency_hz,
                a.damping_ratio,
                b.damping_ratio,
                p.mac
            );
            macs_p.push(p.mac);
            nfds.push(nfd);
            ndds.push(ndd);
        }
        positions.push(json!({
            "position": r.position.index, "label": r.position.label,
            "reference_modes": r.modes.len(), "candidate_modes": c.modes.len(), "paired": pairs.len(),
            "common_dofs": dofs.len(),
            "mean_mac": mean(&macs_p), "min_mac": macs_p.iter().copied().fold(f64::NAN, f64::min),
            "mean_nfd": mean(&nfds), "max_nfd": nfds.iter().copied().fold(f64::NAN, f64::max), "mean_ndd": mean(&ndds),
        }));
        all_mac.extend(macs_p);
        all_nfd.extend(nfds);
        all_ndd.extend(ndds);
    }
    write(&tables.join("pairs.csv"), &pairs_csv)?;
    write(&tables.join("mac.csv"), &mac_csv)?;
    Ok(json!({
        "paired": all_mac.len(), "reference_modes": reference.iter().map(|m| m.modes.len()).sum::<usize>(),
        "mean_mac": mean(&all_mac), "mean_nfd": mean(&all_nfd), "mean_ndd": mean(&all_ndd), "positions": positions,
    }))
}

/// Index in `of` of each of the `lines` (exact match), or `None` when one
/// is missing.
fn line_indices(of: &[f64], lines: &[f64]) -> Option<Vec<usize>> {
    lines
        .iter()
        .map(|f| of.iter().position(|g| g == f))
        .collect()
}

fn compare_frfs(
    reference: &[FrfSet],
    candidate: &[FrfSet],
    initial: Option<&[FrfSet]>,
    tables: &Path,
    plots: &Path,
) -> Result<serde_json::Value, StageError> {
    let mut csv = String::from("position,response,reference,FRAC,CSF\n");
    let mut positions = Vec::new();
    let (mut all_frac, mut all_csf) = (Vec::new(), Vec::new());
    let (mut init_frac, mut init_csf) = (Vec::new(), Vec::new());
    for r in reference {
        let Some(c) = candidate
            .iter()
            .find(|c| c.position.index == r.position.index)
        else {
            continue;
        };
        // Compare on the reference lines the candidate also has (exact match).
        let lines: Vec<(usize, usize)> = r
            .frequencies_hz
            .iter()
            .enumerate()
            .filter_map(|(i, f)| c.frequencies_hz.iter().position(|g| g == f).map(|j| (i, j)))
            .collect();
        if lines.is_empty() {
            return Err(StageError::InvalidInput {
                input: "candidate_frf".into(),
                message: format!(
                    "position {}: no frequency line in common with the reference",
                    r.position.index
                ),
            });
        }
        let (mut fracs, mut csfs) = (Vec::new(), Vec::new());
        let mut plot = Plot::new(
            &format!(
                "FRF overlay, position {} {}",
                r.position.index, r.position.label
            ),
            "frequency [Hz]",
            "|H|",
        );
        plot.y_log = true;
        let f: Vec<f64> = lines.iter().map(|&(i, _)| r.frequencies_hz[i]).collect();
        // The initial model's FRFs of this position, on the compared lines.
        let initial_set = initial
            .and_then(|sets| sets.iter().find(|s| s.position.index == r.position.index))
            .and_then(|s| line_indices(&s.frequencies_hz, &f).map(|idx| (s, idx)));
        for ch in &r.channels {
            let Some(cc) = c.channel(ch.response, ch.reference) else {
                continue;
            };
            let a: Vec<Complex64> = lines.iter().map(|&(i, _)| ch.values[i]).collect();
            let b: Vec<Complex64> = lines.iter().map(|&(_, j)| cc.values[j]).collect();
            let (fr, cs) = (metrics::frac(&a, &b), metrics::csf(&a, &b));
            let _ = writeln!(
                csv,
                "{},{},{},{fr},{cs}",
                r.position.index, ch.response, ch.reference
            );
            let before: Option<Vec<Complex64>> = initial_set.as_ref().and_then(|(s, idx)| {
                let c0 = s.channel(ch.response, ch.reference)?;
                Some(idx.iter().map(|&j| c0.values[j]).collect())
            });
            if let Some(h0) = &before {
                init_frac.push(metrics::frac(&a, h0));
                init_csf.push(metrics::csf(&a, h0));
            }
            // Up to three channels as reference/candidate pairs, or two as
            // reference/initial/candidate triples.
            let per = if initial.is_some() { 3 } else { 2 };
            if plot.series.len() + per <= 6 {
                let k = plot.series.len() / per;
                let curve =
                    |h: &[Complex64]| f.iter().zip(h).map(|(f, h)| (*f, h.norm())).collect();
                let name = |what: &str| format!("{}/{} {what}", ch.response, ch.reference);
                plot.series
                    .push(Series::line(name("reference"), curve(&a), PALETTE[per * k]));
                if let Some(h0) = &before {
                    plot.series.push(Series::line(
                        name("initial"),
                        curve(h0),
                        PALETTE[per * k + 2],
                    ));
                }
                plot.series.push(Series::line(
                    name("candidate"),
                    curve(&b),
                    PALETTE[per * k + 1],
                ));
            }
            fracs.push(fr);
            csfs.push(cs);
        }
        write(
            &plots.join(format!("frf_{}.svg", r.position.index)),
            &plot.to_svg(),
        )?;
        positions.push(json!({"position": r.position.index, "label": r.position.label, "channels": fracs.len(), "mean_frac": mean(&fracs), "mean_csf": mean(&csfs)}));
        all_frac.extend(fracs);
        all_csf.extend(csfs);
    }
    write(&tables.join("frac.csv"), &csv)?;
    let mut summary = json!({"channels": all_frac.len(), "mean_frac": mean(&all_frac), "mean_csf": mean(&all_csf), "positions": positions});
    if initial.is_some() {
        summary["initial_mean_frac"] = json!(mean(&init_frac));
        summary["initial_mean_csf"] = json!(mean(&init_csf));
    }
    Ok(summary)
}

/// `parameter → value` from a parameters.csv (`parameter,value,...`).
pub fn read_parameters(path: &Path, input: &str) -> Result<BTreeMap<String, f64>, StageError> {
    let bad = |message: String| StageError::InvalidInput {
        input: input.into(),
        message,
    };
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| bad(format!("not a parameters.csv: {e}")))?;
    let headers = reader.headers().map_err(|e| bad(e.to_string()))?.clone();
    let col = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| {
            bad(format!(
                "no `{name}` column (columns: {})",
                headers.iter().collect::<Vec<_>>().join(", ")
            ))
        })
    };
    let (pc, vc) = (col("parameter")?, col("value")?);
    let mut out = BTreeMap::new();
    for (line, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let v: f64 = rec
            .get(vc)
            .unwrap_or_default()
            .trim()
            .parse()
            .map_err(|_| bad(format!("line {}: value is not a number", line + 2)))?;
        if !v.is_finite() {
            return Err(bad(format!("line {}: value is not finite", line + 2)));
        }
        out.insert(rec.get(pc).unwrap_or_default().to_string(), v);
    }
    Ok(out)
}

fn compare_parameters(
    truth: &BTreeMap<String, f64>,
    estimate: &BTreeMap<String, f64>,
    tables: &Path,
) -> Result<serde_json::Value, StageError> {
    let mut csv = String::from("parameter,truth,estimate,relative_error,log10_ratio\n");
    let mut rel = Vec::new();
    for (name, &t) in truth {
        let Some(&e) = estimate.get(name) else {
            continue;
        };
        let r = (e - t) / t;
        let _ = writeln!(csv, "{name},{t},{e},{r},{}", (e / t).abs().log10());
        rel.push(r.abs());
    }
    if rel.is_empty() {
        return Err(StageError::InvalidInput {
            input: "estimate".into(),
            message: "no parameter in common with the truth".into(),
        });
    }
    write(&tables.join("parameter_errors.csv"), &csv)?;
    let max = rel.iter().copied().fold(0.0, f64::max);
    Ok(
        json!({"parameters": rel.len(), "mean_abs_relative_error": mean(&rel), "max_abs_relative_error": max}),
    )
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}
