//! The `synthesize` kind: reference data with a known truth. Solves a model
//! file at given parameter values for every axis position and writes what a
//! measurement would give — FRFs at the sensors (modal superposition, eq.
//! 2.42/2.45, optionally spoiled by noise or a simulated impact test) — plus
//! the truth: modes, parameter values and the resolved model.
//!
//! Outputs: `frf` (UFF 58b, one data set per position), `modes` (modes.csv
//! and mode_shapes.csv of the modes inside the frequency band), `model`
//! (model.json: the model file's text, referenced files and the values used,
//! so downstream stages can rebuild it), `truth` (parameters.csv).

use crate::artifacts;
mod params;
mod values;

use super::params::model_files::{external_files, facts, load_model, referenced_files};
use super::{
    Artifact, FileRef, InputSpec, Kind, ParamProblem, StageContext, StageError, StageOutputs,
};
use crate::artifacts::model::{ModelJson, ModelParameter, ModelPosition};
use crate::artifacts::parameters::TruthRow;
use crate::dynamics::measurement;
use crate::dynamics::model_file::{self, ParameterKind};
use crate::dynamics::solve::ModeSelection;
use crate::dynamics::{Model, PreparedModel};
use crate::frf::{Dof, FrfSet};
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;
use params::{self as sp, Modes, Params, PositionRef};
use rayon::prelude::*;
use std::path::Path;
use values::{override_from_table, significant_parameters, values};

pub struct Synthesize;

fn problem(path: &[&str], message: String, help: &str) -> ParamProblem {
    ParamProblem::new(path, message, help)
}

/// The synthesized FRFs against the memory limit: complex lines ×
/// sensors × excitations × positions, twice (the FRFs and the noisy or
/// measured copy with its coherence).
fn frf_memory(p: &Params, spec: &model_file::ModelFile) -> Option<ParamProblem> {
    let g = p.frequency;
    let lines = ((g.max - g.min) / g.step).max(0.0) + 1.0;
    let count = |given: Option<usize>, all: usize| given.unwrap_or(all).max(1) as f64;
    let sensors = count(p.sensors.as_ref().map(Vec::len), spec.sensors.len());
    let excitations = count(p.excitations.as_ref().map(Vec::len), spec.excitations.len());
    let all_positions = spec.axes.iter().map(|a| a.positions.len().max(1)).product();
    let positions = count(p.positions.as_ref().map(Vec::len), all_positions);
    crate::stages::params::limits::memory_problem(
        &["frequency", "step"],
        &format!(
            "{lines} lines × {sensors} sensors × {excitations} excitations × {positions} positions"
        ),
        2.0 * 16.0 * lines * sensors * excitations * positions,
    )
}

/// Configuration indices selected by `positions` (indices or labels).
fn positions(prepared: &PreparedModel, sel: Option<&[PositionRef]>) -> Result<Vec<usize>, String> {
    let Some(sel) = sel else {
        return Ok((0..prepared.configurations.len()).collect());
    };
    let labels: Vec<&str> = prepared
        .configurations
        .iter()
        .map(|c| c.position.label.as_str())
        .collect();
    sel.iter()
        .map(|v| {
            let hit = match v {
                PositionRef::Index(i) => Some(*i).filter(|&i| i < labels.len()),
                PositionRef::Label(s) => labels.iter().position(|l| l == s),
            };
            hit.ok_or_else(|| {
                let v = match v {
                    PositionRef::Index(i) => i.to_string(),
                    PositionRef::Label(s) => format!("`{s}`"),
                };
                if labels.len() == 1 && labels[0].is_empty() {
                    format!(
                        "no position {v}: the model has no axes, so one unnamed position (index 0)"
                    )
                } else {
                    format!("no position {v} (positions: {})", labels.join(", "))
                }
            })
        })
        .collect()
}

fn subset(all: &[(String, Dof)], names: Option<&[String]>, what: &str) -> Result<Vec<Dof>, String> {
    let Some(names) = names else {
        return Ok(all.iter().map(|s| s.1).collect());
    };
    names
        .iter()
        .map(|n| {
            all.iter().find(|s| &s.0 == n).map(|s| s.1).ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|s| s.0.as_str()).collect();
                format!(
                    "{what}: the model has no {what} named `{n}` ({})",
                    known.join(", ")
                )
            })
        })
        .collect()
}

impl Kind for Synthesize {
    type Params = Params;
    const NAME: &'static str = "synthesize";
    const FILE_PARAMS: &'static [(&'static str, bool)] = &[("model", false)];

    /// 2: true modes in the pole convention of the FRFs (hysteretic modes
    /// at |λ|, [`crate::dynamics::solve::mode_pole`]). 3: the modes
    /// artifact states its mass-normalized scaling (scaling.json). 4: modes
    /// by shift-invert block Lanczos (last bits of frequencies and shapes
    /// change, issue 16).
    fn version(&self) -> u32 {
        // v5: Lanczos orthogonalization/basis/tolerance (issue 16) change
        // eigenpairs in the last bits. v6: modes.csv always has the
        // position columns (one shape for every writer, issue 31). v7: the
        // Lanczos starts in the operator's range, the shift is chosen from
        // the problem (free-free models: rigid-body modes detected), the
        // residual check is per mode (issue 32): eigenpairs change. v8:
        // model.json and parameters.csv written through their schemas
        // (`schema_version` stated, fields in schema order; issue 28); more
        // than 40 modes are found in locked chunks (issue 32). v9: model.json
        // refers to the matrix files by path, size and blake3 (schema 3),
        // never embeds their text; locked chunks carry their unconverged
        // Ritz vectors on and use a 4× basis, the shift choice solves 8
        // modes to 1e-3, the sparse factor keeps the natural ordering when
        // it fills less than AMD (issue 32): eigenpairs of sparse models
        // may change in the last bits. v10: a simulated impact test of a
        // model with hysteretic damping adds the structure's excess
        // receptance over its poles' viscous stand-in
        // (`measurement::hysteretic`; issue 26): its FRFs change.
        10
    }
    fn summary(&self) -> &'static str {
        "solve a model file and write reference FRFs (with noise or a simulated impact test), modes and the truth"
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(&[
            InputSpec {
                name: "values",
                required: false,
                list: false,
                artifact: Artifact::Parameters,
                doc: "a parameter table (`parameter,value,...`: an identify stage's `parameters`, a synthesize `truth`) whose values override the model's, applied after the `values` param: the updated model's FRFs and modes",
            },
            InputSpec {
                name: "significant",
                required: false,
                list: false,
                artifact: Artifact::Significant,
                doc: "a gsa `significant` table (significant.csv): `values.perturb` moves only its significant parameters (PUB3 scenario 1 that follows the screening)",
            },
        ])
    }
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("frf", Artifact::Frf),
        ("modes", Artifact::Modes),
        ("model", Artifact::Model),
        ("truth", Artifact::Parameters),
    ];
    fn uses_seed(&self) -> bool {
        true
    }
    fn seed(&self, p: &Params) -> Option<u64> {
        p.seed
    }
    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        sp::check(p)
    }
    fn files(&self, p: &Params) -> Vec<FileRef> {
        vec![FileRef {
            param: "model".into(),
            path: p.model.clone(),
            glob: false,
        }]
    }

    fn file_dependencies(&self, p: &Params, dir: &Path) -> Result<Vec<String>, ParamProblem> {
        let (model, text) = facts(dir, &p.model).map_err(|m| {
            problem(
                &["model"],
                m,
                "fix the model file; see pipelines/models/ for examples",
            )
        })?;
        values(&model.parameters, p.values.as_ref(), None).map_err(|m| {
            problem(
                &["values"],
                m,
                "use the model's parameter names and stay within bounds",
            )
        })?;
        if let Some(problem) = model.memory_problem() {
            return Err(problem);
        }
        let finite = model.finite_modes;
        if let Some(Modes::Count(k)) = p.modes {
            if k > finite {
                return Err(problem(
                    &["modes"],
                    format!(
                        "{k} modes asked, but the model has only {finite} DOFs with mass ({} massless DOFs, such as rotations or constraint nodes of a lumped-mass export, have no finite frequency)",
                        model.n_dofs - finite
                    ),
                    "ask for fewer modes, or `modes: {below: <Hz>}`",
                ));
            }
        }
        let spec = model_file::parse(&text, &p.model)
            .map_err(|e| problem(&["model"], e.to_string(), ""))?;
        let check_names = |names: Option<&[String]>,
                           list: &[model_file::PointDofSpec],
                           what: &str|
         -> Result<(), ParamProblem> {
            for n in names.unwrap_or_default() {
                if !list.iter().any(|s| &s.name == n) {
                    let known: Vec<&str> = list.iter().map(|s| s.name.as_str()).collect();
                    return Err(problem(
                        &[&format!("{what}s")],
                        format!("the model has no {what} `{n}` ({})", known.join(", ")),
                        "use a name from the model file",
                    ));
                }
            }
            Ok(())
        };
        check_names(p.sensors.as_deref(), &spec.sensors, "sensor")?;
        check_names(p.excitations.as_deref(), &spec.excitations, "excitation")?;
        if let Some(problem) = frf_memory(p, &spec) {
            return Err(problem);
        }
        if let Some(imp) = &p.impact_test {
            let model = Some((model.n_dofs, spec.sensors.len()));
            if let Some(problem) = sp::impact_resources(p, imp, model).into_iter().next() {
                return Err(problem);
            }
        }
        Ok(external_files(&spec, &p.model))
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let invalid = |param: &str, message: String| StageError::InvalidParam {
            param: param.into(),
            message,
        };
        let (model, text) =
            load_model(ctx.pipeline_dir, &p.model).map_err(|m| invalid("model", m))?;
        let only = match ctx.inputs.get("significant") {
            Some(_) => Some(significant_parameters(ctx.input("significant")?, p)?),
            None => None,
        };
        let mut x = values(&model.parameters, p.values.as_ref(), only.as_deref())
            .map_err(|m| invalid("values", m))?;
        if ctx.inputs.contains_key("values") {
            override_from_table(&model, &mut x, ctx.input("values")?)?;
        }
        ctx.progress
            .set_message("preparing model (reductions)".into());
        let prepared = PreparedModel::new(&model).map_err(|e| invalid("model", e.to_string()))?;
        let configs =
            positions(&prepared, p.positions.as_deref()).map_err(|m| invalid("positions", m))?;
        let sensors = subset(&prepared.sensors, p.sensors.as_deref(), "sensor")
            .map_err(|m| invalid("sensors", m))?;
        let excitations = subset(
            &prepared.excitations,
            p.excitations.as_deref(),
            "excitation",
        )
        .map_err(|m| invalid("excitations", m))?;
        let grid = p.frequency;
        let quantity = p.quantity.into();
        let selection = match p.modes {
            Some(Modes::Count(n)) => ModeSelection::Lowest(n),
            Some(Modes::Below { below }) => ModeSelection::Below(below),
            None => ModeSelection::Below(2.0 * grid.max),
        };
        let seed = ctx.seed;
        ctx.progress.set_length(configs.len() as u64);
        ctx.progress.set_message("solving positions".into());
        let per_position: Vec<Result<(FrfSet, ModalModel), StageError>> = configs
            .par_iter()
            .map(|&c| {
                let r = synthesize_position(
                    &prepared,
                    c,
                    &x,
                    selection,
                    &sensors,
                    &excitations,
                    p,
                    quantity,
                    seed,
                );
                ctx.progress.inc(1);
                r
            })
            .collect();
        let mut sets = Vec::new();
        let mut truth = Vec::new();
        for r in per_position {
            let (set, modes) = r?;
            sets.push(set);
            truth.push(modes);
        }
        let n_modes: usize = truth.iter().map(|m| m.modes.len()).sum();
        artifacts::frf::write(&ctx.scratch.join(artifacts::frf::FILE), &sets)?;
        artifacts::modes::write_mass_normalized_modes(
            &ctx.scratch.join(artifacts::modes::DIR),
            &truth,
        )?;
        write_model_json(ctx, &model, &text, &p.model, &x, &prepared)?;
        write_truth_csv(ctx, &model, &x)?;
        Ok(StageOutputs {
            warnings: impact_step_warning(p, quantity).into_iter().collect(),
            files: vec![
                ("frf".into(), artifacts::frf::FILE.into()),
                ("modes".into(), artifacts::modes::DIR.into()),
                ("model".into(), "model.json".into()),
                ("truth".into(), "parameters.csv".into()),
            ],
            counters: [
                ("positions".to_string(), configs.len() as u64),
                ("modes".to_string(), n_modes as u64),
                ("dofs".to_string(), prepared.n_dofs() as u64),
            ]
            .into(),
        })
    }
}

#[allow(clippy::too_many_arguments)]
fn synthesize_position(
    prepared: &PreparedModel,
    config: usize,
    x: &[f64],
    selection: ModeSelection,
    sensors: &[Dof],
    excitations: &[Dof],
    p: &Params,
    quantity: crate::frf::FrfQuantity,
    seed: u64,
) -> Result<(FrfSet, ModalModel), StageError> {
    let failed = |e: &dyn std::fmt::Display| StageError::Failed(format!("position {config}: {e}"));
    let sol = prepared
        .evaluate_modes(config, x, selection)
        .map_err(|e| failed(&e))?;
    let grid = p.frequency;
    // Per-position noise stream: positions are independent measurements.
    let pos_seed = seed ^ (config as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let set = if let Some(imp) = &p.impact_test {
        let params = imp.resolve(&grid, quantity);
        let dof_model = modal_model_at(prepared, &sol, sensors, excitations);
        // Hysteretic modal damping has no causal impulse response: the test
        // is simulated from the poles plus the structure's excess receptance.
        let excess = measurement::HystereticExcess::new(&sol.eigenvalues, &sol.zeta, &sol.eta);
        let mut set: Option<FrfSet> = None;
        for (k, &exc) in excitations.iter().enumerate() {
            let s = measurement::simulate_impact_test_with(
                &dof_model,
                excess.as_ref(),
                exc,
                sensors,
                &params,
                pos_seed.wrapping_add(k as u64),
            )
            .map_err(|e| failed(&e))?;
            match &mut set {
                None => set = Some(s),
                Some(all) => all.channels.extend(s.channels),
            }
        }
        let mut set = set.ok_or_else(|| failed(&"the model has no excitation"))?;
        set.position = prepared.configurations[config].position.clone();
        set
    } else {
        let mut set = prepared
            .frf_superposition(&sol, quantity, &grid.lines())
            .map_err(|e| failed(&e))?;
        set.channels
            .retain(|c| sensors.contains(&c.response) && excitations.contains(&c.reference));
        match &p.noise {
            Some(n) if n.relative > 0.0 => {
                measurement::add_relative_noise(&set, n.relative, pos_seed)
                    .map_err(|e| failed(&e))?
            }
            _ => set,
        }
    };
    let mut modes = prepared.modal_model(&sol).map_err(|e| failed(&e))?;
    let keep: Vec<usize> = modes
        .dofs
        .iter()
        .enumerate()
        .filter(|(_, d)| sensors.contains(d))
        .map(|(i, _)| i)
        .collect();
    modes.dofs = keep.iter().map(|&i| modes.dofs[i]).collect();
    modes
        .modes
        .retain(|m| m.frequency_hz >= grid.min && m.frequency_hz <= grid.max);
    for m in &mut modes.modes {
        m.shape = keep.iter().map(|&i| m.shape[i]).collect();
    }
    Ok((set, modes))
}

/// Mass-normalized modes at the sensor and excitation DOFs, as the impact
/// simulation needs both ends of every FRF.
fn modal_model_at(
    prepared: &PreparedModel,
    sol: &crate::dynamics::solve::ModalSolution,
    sensors: &[Dof],
    excitations: &[Dof],
) -> ModalModel {
    let mut rows: Vec<(Dof, Vec<f64>)> = Vec::new();
    let n = sol.eigenvalues.len();
    for (i, (_, d)) in prepared.sensors.iter().enumerate() {
        if sensors.contains(d) && !rows.iter().any(|r| r.0 == *d) {
            rows.push((*d, (0..n).map(|r| sol.sensor_shapes[(i, r)]).collect()));
        }
    }
    for (i, (_, d)) in prepared.excitations.iter().enumerate() {
        if excitations.contains(d) && !rows.iter().any(|r| r.0 == *d) {
            rows.push((*d, (0..n).map(|r| sol.excitation_shapes[(i, r)]).collect()));
        }
    }
    let f = sol.frequencies_hz();
    let z = sol.damping_ratios();
    ModalModel {
        position: prepared.configurations[sol.config].position.clone(),
        dofs: rows.iter().map(|r| r.0).collect(),
        modes: (0..n)
            .map(|r| Mode {
                frequency_hz: f[r],
                damping_ratio: z[r],
                shape: rows
                    .iter()
                    .map(|row| Complex64::new(row.1[r], 0.0))
                    .collect(),
            })
            .collect(),
    }
}

fn kind_text(k: ParameterKind) -> &'static str {
    match k {
        ParameterKind::Stiffness => "stiffness",
        ParameterKind::Damping => "damping",
    }
}

fn write_model_json(
    ctx: &StageContext,
    model: &Model,
    text: &str,
    rel: &str,
    x: &[f64],
    prepared: &PreparedModel,
) -> Result<(), StageError> {
    // By reference: each referenced file's path, size and blake3 (the hashes
    // of the bytes this run built the model from), never its text.
    let files = referenced_files(ctx.pipeline_dir, rel).map_err(StageError::Failed)?;
    let json = ModelJson {
        schema_version: Default::default(),
        file: Path::new(rel)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned()),
        path: Some(rel.replace('\\', "/")),
        yaml: text.to_string(),
        files,
        external: Default::default(),
        parameters: model
            .parameters
            .iter()
            .zip(x)
            .map(|(p, &value)| ModelParameter {
                name: p.name.clone(),
                value,
                lower: p.lower,
                upper: p.upper,
                scale: p.scale.as_str().into(),
                kind: kind_text(p.kind).into(),
            })
            .collect(),
        positions: prepared
            .configurations
            .iter()
            .map(|c| ModelPosition {
                index: c.position.index,
                label: c.position.label.clone(),
            })
            .collect(),
        dofs: prepared.n_dofs(),
    };
    Ok(json.write(&ctx.scratch.join(crate::artifacts::model::FILE))?)
}

fn write_truth_csv(ctx: &StageContext, model: &Model, x: &[f64]) -> Result<(), StageError> {
    let rows: Vec<TruthRow> = model
        .parameters
        .iter()
        .zip(x)
        .map(|(p, &value)| TruthRow {
            parameter: p.name.clone(),
            value,
            lower: p.lower,
            upper: p.upper,
            scale: p.scale.as_str().into(),
            kind: kind_text(p.kind).into(),
        })
        .collect();
    Ok(crate::artifacts::parameters::write(
        &ctx.scratch.join(crate::artifacts::parameters::FILE),
        &rows,
    )?)
}

/// An impact test's FRF lines are `sample_rate_hz / block_size` apart,
/// whatever `frequency.step` says: a step that differs is not silently
/// replaced but named, with the fix.
fn impact_step_warning(p: &Params, quantity: crate::frf::FrfQuantity) -> Option<String> {
    let imp = p.impact_test.as_ref()?;
    let resolved = imp.resolve(&p.frequency, quantity);
    let line = resolved.sample_rate_hz / resolved.block_size as f64;
    let step = p.frequency.step;
    ((line - step).abs() > 1e-9 * line.max(step)).then(|| {
        format!(
            "impact_test: the FRF lines are sample_rate_hz / block_size = {} / {} = {} Hz apart, \
             so frequency.step = {} is not used; set frequency.step to {} or block_size to \
             sample_rate_hz / step",
            crate::report::format::sig(resolved.sample_rate_hz, 4),
            resolved.block_size,
            crate::report::format::sig(line, 4),
            crate::report::format::sig(step, 4),
            crate::report::format::sig(line, 4),
        )
    })
}
