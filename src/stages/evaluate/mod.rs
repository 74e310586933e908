//! The `evaluate` kind: how well a candidate (identified or updated) model
//! matches a reference, by the criteria of seed section 2.3.4 — MAC matrix,
//! MACXP, NFD, NDD of paired modes (eq. 2.62–2.65), FRAC and CSF of FRFs
//! (eq. 2.66–2.67) — and, when the truth is known, parameter errors.
//!
//! Modes are paired per position by one optimal assignment on
//! (1 − MAC) + NFD/`frequency_scale` within the `window` and above
//! `min_mac` ([`crate::pairing`]), on the DOFs both models share; each
//! pair's margin says how sure it is, and what the pairing leaves over
//! (missed reference modes, spurious candidate modes, ambiguous pairs) is
//! listed in metrics.json. An optional `cost` input (an identify
//! cost.json) copies the identification's verdict into metrics.json.
//!
//! metrics.json has one schema, [`crate::artifacts::metrics::Metrics`], for
//! the writer and readers.

mod frf;
pub mod geometry;
mod modes;
mod parameters;

use super::{
    Artifact, InputSpec, Kind, ParamProblem, Range, StageContext, StageError, StageOutputs,
};
use crate::artifacts::cost::Cost;
use crate::artifacts::frf::{read_scaled as read_frf_scaled, uncalibrated_refused};
use crate::artifacts::metrics::Metrics;
use crate::artifacts::modes::read_modes;
use crate::artifacts::parameters::read_values as read_parameters;
use crate::pairing::Pairing;
use std::path::Path;

pub struct Evaluate;

crate::params! {
    /// The `evaluate` kind's params: the mode pairing.
    pub struct Params {
        /// relative frequency window for pairing modes (0.2 = ±20 %)
        pub window: f64 = 0.2; range Range::above(0.0),
        /// minimum MAC of a pair
        pub min_mac: f64 = 0.3; range Range::closed(0.0, 1.0),
        /// pairing cost (1 − MAC) + NFD/frequency_scale: the NFD that costs
        /// as much as MAC 0
        pub frequency_scale: f64 = Pairing::default().frequency_scale; range Range::above(0.0),
        /// a pair whose margin (cost increase if it were forbidden) is below
        /// this is ambiguous
        pub ambiguity: f64 = Pairing::default().ambiguity; range Range::at_least(0.0),
        /// the model's vertical axis (`x`, `y` or `z`): mode-shape views are
        /// then named top, front and side, the vertical axis drawn upward;
        /// default: the geometry's model file's `vertical:`; with neither,
        /// views are named by their plane
        pub vertical: Option<String> = None,
    }
}

/// The index (0–2) of the `vertical` param's axis, if given and valid.
fn vertical_axis(p: &Params) -> Option<usize> {
    match p.vertical.as_deref()? {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    }
}

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "reference",
        required: false,
        list: false,
        artifact: Artifact::Modes,
        doc: "reference modes (e.g. synthesize.modes)",
    },
    InputSpec {
        name: "candidate",
        required: false,
        list: false,
        artifact: Artifact::Modes,
        doc: "candidate modes (e.g. autoema.modes)",
    },
    InputSpec {
        name: "reference_frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "reference FRFs",
    },
    InputSpec {
        name: "candidate_frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "candidate FRFs on the same lines (e.g. autoema.frf_fit)",
    },
    InputSpec {
        name: "initial_frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "FRFs before updating (e.g. a synthesize stage at the start values): a third curve in the overlays and their FRAC/CSF as `initial_mean_frac`/`initial_mean_csf`",
    },
    InputSpec {
        name: "truth",
        required: false,
        list: false,
        artifact: Artifact::Parameters,
        doc: "true parameters (synthesize.truth)",
    },
    InputSpec {
        name: "estimate",
        required: false,
        list: false,
        artifact: Artifact::Parameters,
        doc: "estimated parameters (parameters.csv)",
    },
    InputSpec {
        name: "geometry",
        required: false,
        list: false,
        artifact: Artifact::Json,
        doc: "the structure to draw paired mode shapes on: a synthesize stage's `model` (sensor points of the model file) or an import stage's `geometry` (UFF 15/2411 nodes, 82 trace lines)",
    },
    InputSpec {
        name: "cost",
        required: false,
        list: false,
        artifact: Artifact::Cost,
        doc: "the identify cost.json of the candidate: its verdict is copied into metrics.json",
    },
];

/// The pairing settings of the params.
fn pairing(p: &Params) -> Pairing {
    Pairing {
        window: p.window,
        min_mac: p.min_mac,
        frequency_scale: p.frequency_scale,
        ambiguity: p.ambiguity,
    }
}

impl Kind for Evaluate {
    type Params = Params;
    const NAME: &'static str = "evaluate";

    /// 2: modes paired by frequency and MAC. 3: pair margins, unpaired and
    /// ambiguous modes, the identification's verdict. 4: FRFs compared in the
    /// reference's quantity, figures to the style guide (magnitude + phase,
    /// titled MAC axes), mode shapes on the geometry. 5: shapes and FRF
    /// channels pair by node and axis, a transducer of opposite sign
    /// flipping the sign (a test's −Z against a model's +Z). 6: metrics.json
    /// states `schema_version` (issue 28). 7: every FRF channel drawn
    /// (small multiples, `frf_channels_<position>.svg`), figure titles name
    /// the candidate, paired shapes sign-aligned and views named by plane.
    /// 8: without the `vertical` param, the views are named from the
    /// geometry's model file (its `vertical:` key).
    fn version(&self) -> u32 {
        8
    }
    fn summary(&self) -> &'static str {
        "compare candidate modes/FRFs/parameters with a reference: MAC, MACXP, NFD, NDD, FRAC, CSF, parameter errors, unpaired and ambiguous modes, the identification's verdict"
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("metrics", Artifact::Metrics),
        ("tables", Artifact::Tables),
        ("plots", Artifact::Figure),
    ];
    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        let mut problems = match pairing(p).check() {
            Ok(()) => Vec::new(),
            // The message starts with the setting's name, which is the param's.
            Err(message) => vec![ParamProblem::new(
                &[message.split_whitespace().next().unwrap_or_default()],
                message.clone(),
                "see `modalflow kinds` for the evaluate params",
            )],
        };
        if let (Some(v), None) = (&p.vertical, vertical_axis(p)) {
            problems.push(ParamProblem::new(
                &["vertical"],
                format!("`{v}` is not an axis"),
                "write x, y or z (the model's vertical axis)",
            ));
        }
        problems
    }
    fn check_inputs(&self, _p: &Params, bound: &[&str]) -> Vec<ParamProblem> {
        let has = |n: &str| bound.contains(&n);
        let pairs_ok = (has("reference") && has("candidate"))
            || (has("reference_frf") && has("candidate_frf"))
            || (has("truth") && has("estimate"));
        if pairs_ok {
            return Vec::new();
        }
        vec![ParamProblem::new(
            &[],
            "nothing to compare",
            "bind reference+candidate, reference_frf+candidate_frf, or truth+estimate",
        )]
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let has = |n: &str| ctx.has(n);
        let settings = pairing(p);
        let tables = ctx.scratch.join("tables");
        let plots = ctx.scratch.join("plots");
        for d in [&tables, &plots] {
            std::fs::create_dir_all(d)
                .map_err(|e| StageError::io("cannot create output directory", e))?;
        }
        let mut summary = Metrics::default();
        if has("reference") && has("candidate") {
            let reference = read_modes(ctx.input("reference")?, "reference")?;
            let candidate = read_modes(ctx.input("candidate")?, "candidate")?;
            let geometry = if has("geometry") {
                Some(geometry::read(ctx.input("geometry")?)?)
            } else {
                None
            };
            let at = |position: u32| geometry.as_ref().and_then(|g| g.at(position));
            summary.modes = Some(modes::compare_modes(
                &reference,
                &candidate,
                &settings,
                geometry.as_ref().map(|_| &at as &dyn Fn(u32) -> Option<_>),
                // The param overrides the model file's `vertical:`.
                vertical_axis(p).or_else(|| geometry.as_ref().and_then(|g| g.vertical())),
                &tables,
                &plots,
            )?);
        }
        if has("reference_frf") && has("candidate_frf") {
            let (r, r_cal) = read_frf_scaled(ctx.input("reference_frf")?, "reference_frf")?;
            let (c, c_cal) = read_frf_scaled(ctx.input("candidate_frf")?, "candidate_frf")?;
            let (initial, i_cal) = if has("initial_frf") {
                let (i, cal) = read_frf_scaled(ctx.input("initial_frf")?, "initial_frf")?;
                (Some(i), cal)
            } else {
                (None, r_cal)
            };
            // Uncalibrated FRFs compare only with FRFs of the same scale
            // (AutoEMA's fit of them), never with a model's in m/N.
            if let Some(input) = [("candidate_frf", c_cal), ("initial_frf", i_cal)]
                .iter()
                .find(|(_, cal)| *cal != r_cal)
                .map(|(n, cal)| if *cal { "reference_frf" } else { n })
            {
                return Err(StageError::from(uncalibrated_refused(
                    "evaluate",
                    input,
                    "FRAC/CSF against a calibrated FRF (a model's or a measurement's in SI units)",
                )));
            }
            // The candidate's stage names the figures (`updated[run=pso]`).
            let name = ctx
                .sources
                .get("candidate_frf")
                .and_then(|s| s.first())
                .map_or_else(|| "the candidate".to_string(), |s| s.stage.clone());
            summary.frf = Some(frf::compare_frfs(
                &r,
                &c,
                initial.as_deref(),
                &name,
                &tables,
                &plots,
            )?);
        }
        if has("truth") && has("estimate") {
            let t = read_parameters(ctx.input("truth")?, "truth")?;
            let e = read_parameters(ctx.input("estimate")?, "estimate")?;
            summary.parameters = Some(parameters::compare_parameters(&t, &e, &tables)?);
        }
        if has("cost") {
            let cost = Cost::read(ctx.input("cost")?).map_err(|e| StageError::InvalidInput {
                input: "cost".into(),
                message: format!("{e}; bind an identify stage's `cost` output"),
            })?;
            if !cost.verdict.ok {
                ctx.progress
                    .set_message(format!("verdict: {}", cost.verdict.message));
            }
            summary.verdict = Some(cost.verdict);
        }
        let path = ctx.scratch.join(crate::artifacts::metrics::FILE);
        summary.write(&path)?;
        Ok(StageOutputs {
            warnings: Vec::new(),
            files: vec![
                ("metrics".into(), path),
                ("tables".into(), tables),
                ("plots".into(), plots),
            ],
            counters: Default::default(),
        })
    }
}

fn write(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), StageError> {
    std::fs::write(path, bytes)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// The mean of `v`, `None` when empty or not finite.
fn mean(v: &[f64]) -> Option<f64> {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (!v.is_empty() && m.is_finite()).then_some(m)
}

/// The extreme of `v` by `pick` (`f64::min`, `f64::max`), `None` when empty.
fn extreme(v: &[f64], pick: fn(f64, f64) -> f64) -> Option<f64> {
    v.iter().copied().reduce(pick).filter(|x| x.is_finite())
}
