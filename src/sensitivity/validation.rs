//! Monte Carlo validation of a significant/non-significant split (PUB2, seed
//! section 5.2.1): the significant parameters stay at their reference
//! ("true") values while the non-significant ones are drawn at random within
//! their bounds (uniformly in their scale: log-uniform for log parameters);
//! every model output is compared with its value at the reference point.
//! If the split is right, the model barely notices the random parameters.
//!
//! Conformity of one output for one sample:
//! - criteria that already measure agreement with the reference (MAC, FRAC,
//!   CSF: outputs named `*.mac`, `*.frac`, `*.csf`) are taken as they are;
//! - any other output y counts by its relative agreement with the reference
//!   value y₀, max(0, 1 − |y − y₀| / |y₀|) (1 − |NFD| for an eigenfrequency,
//!   eq. 2.64).
//!
//! PUB2 reports the minimum and the mean conformity over all samples and
//! outcomes (89 % and 98.9 % for 22 of 71 parameters kept).

use super::SensitivityError;
use crate::simulator::{evaluate_all, Model};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// How an output's conformity is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ConformityKind {
    /// MAC, FRAC or CSF: the value itself.
    Criterion,
    /// max(0, 1 − |y − y₀| / |y₀|).
    Relative,
}

impl ConformityKind {
    /// The kind an output name implies.
    pub fn of(output: &str) -> ConformityKind {
        let criterion = [".mac", ".frac", ".csf"]
            .iter()
            .any(|s| output.ends_with(s));
        if criterion {
            ConformityKind::Criterion
        } else {
            ConformityKind::Relative
        }
    }

    pub(crate) fn conformity(self, y: f64, reference: f64) -> f64 {
        match self {
            ConformityKind::Criterion => y,
            ConformityKind::Relative if reference == 0.0 => {
                if y == 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            ConformityKind::Relative => (1.0 - (y - reference).abs() / reference.abs()).max(0.0),
        }
    }
}

/// Conformity statistics of one output over the samples.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutputConformity {
    pub output: String,
    pub kind: ConformityKind,
    /// Value at the reference point.
    pub reference: f64,
    pub min: f64,
    pub mean: f64,
    /// 5 % quantile (nearest rank).
    pub p05: f64,
}

/// The result of a validation run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Validation {
    pub samples: usize,
    pub seed: u64,
    /// Parameters held at their reference values.
    pub fixed: Vec<String>,
    /// Parameters drawn at random.
    pub random: Vec<String>,
    pub outputs: Vec<OutputConformity>,
    /// Minimum and mean conformity over the headline outputs (the criteria
    /// if the model has any, otherwise every output) and all samples.
    pub min: f64,
    pub mean: f64,
    /// Kind of the outputs behind `min` and `mean`.
    pub headline: ConformityKind,
    /// The headline output with the lowest minimum.
    pub worst: String,
}

/// Draw `samples` points with the parameters named in `fixed` at
/// `reference[i]` and all others at random (seeded), evaluate `model` in
/// parallel batches and summarize the conformity of every output.
pub fn validate(
    model: &(impl Model + ?Sized),
    fixed: &[String],
    reference: &[f64],
    samples: usize,
    seed: u64,
    progress: &dyn Fn(u64),
) -> Result<Validation, SensitivityError> {
    let is_fixed = check(model, fixed, reference)?;
    if samples == 0 {
        return Err(SensitivityError::Invalid(
            "validation needs at least one sample, e.g. 1000".into(),
        ));
    }
    let params = model.parameters();
    let units = draw_units(samples, params.len(), seed);
    let points = points(model, reference, &is_fixed, &units);
    let y0 = evaluate_all(model, &[reference.to_vec()], 1, &|_| {})?
        .pop()
        .ok_or_else(|| SensitivityError::Invalid("the model returned no outputs".into()))?;
    let ys = evaluate_all(model, &points, 256, progress)?;

    let names = model.outputs();
    let mut outputs = Vec::with_capacity(names.len());
    for (o, name) in names.iter().enumerate() {
        let kind = ConformityKind::of(name);
        let mut c: Vec<f64> = ys.iter().map(|y| kind.conformity(y[o], y0[o])).collect();
        let mean = c.iter().sum::<f64>() / c.len() as f64;
        c.sort_by(f64::total_cmp);
        let rank = ((0.05 * c.len() as f64).ceil() as usize).clamp(1, c.len()) - 1;
        outputs.push(OutputConformity {
            output: name.clone(),
            kind,
            reference: y0[o],
            min: c[0],
            mean,
            p05: c[rank],
        });
    }
    let headline = headline_kind(names);
    let chosen: Vec<&OutputConformity> = outputs.iter().filter(|o| o.kind == headline).collect();
    let worst = chosen
        .iter()
        .min_by(|a, b| a.min.total_cmp(&b.min))
        .map(|o| o.output.clone())
        .unwrap_or_default();
    let min = chosen.iter().map(|o| o.min).fold(f64::INFINITY, f64::min);
    let mean = chosen.iter().map(|o| o.mean).sum::<f64>() / chosen.len().max(1) as f64;
    Ok(Validation {
        samples,
        seed,
        fixed: fixed.to_vec(),
        random: params
            .iter()
            .filter(|p| !fixed.contains(&p.name))
            .map(|p| p.name.clone())
            .collect(),
        outputs,
        min,
        mean,
        headline,
        worst,
    })
}

/// Which parameters are `fixed` (in model order), after checking the
/// reference point and the names.
pub(crate) fn check(
    model: &(impl Model + ?Sized),
    fixed: &[String],
    reference: &[f64],
) -> Result<Vec<bool>, SensitivityError> {
    let params = model.parameters();
    if reference.len() != params.len() {
        return Err(SensitivityError::Invalid(format!(
            "{} reference values for {} parameters",
            reference.len(),
            params.len()
        )));
    }
    if let Some(name) = fixed.iter().find(|n| !params.iter().any(|p| &p.name == *n)) {
        return Err(SensitivityError::UnknownParameter {
            name: name.clone(),
            known: params.iter().map(|p| p.name.clone()).collect(),
        });
    }
    Ok(params.iter().map(|p| fixed.contains(&p.name)).collect())
}

/// Unit coordinates of `samples` points, one for every parameter whether
/// fixed or not, drawn in sequence from one seeded stream: they do not
/// depend on how the evaluation is parallelized, and every split of the
/// parameters sees the same draws (common random numbers, so splits that
/// differ by one parameter differ only in that parameter's coordinates).
pub(crate) fn draw_units(samples: usize, d: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..samples)
        .map(|_| (0..d).map(|_| rng.random::<f64>()).collect())
        .collect()
}

/// The points of `units`: fixed parameters at `reference`, the others at
/// their unit coordinate mapped into their bounds (in their scale).
pub(crate) fn points(
    model: &(impl Model + ?Sized),
    reference: &[f64],
    is_fixed: &[bool],
    units: &[Vec<f64>],
) -> Vec<Vec<f64>> {
    let params = model.parameters();
    units
        .iter()
        .map(|u| {
            params
                .iter()
                .zip(reference)
                .zip(is_fixed)
                .zip(u)
                .map(|(((p, &r), &f), &u)| if f { r } else { p.from_unit(u) })
                .collect()
        })
        .collect()
}

/// The kind of the headline outputs: the criteria if the model has any,
/// otherwise every output.
pub(crate) fn headline_kind(names: &[String]) -> ConformityKind {
    if names
        .iter()
        .any(|n| ConformityKind::of(n) == ConformityKind::Criterion)
    {
        ConformityKind::Criterion
    } else {
        ConformityKind::Relative
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::SobolG;

    /// Sobol-G with a = 0 for x1 (dominant) and a = 99 for the rest: y ≈ G1(x1).
    fn model() -> SobolG {
        SobolG::new(vec![0.0, 99.0, 99.0, 99.0]).expect("valid a")
    }

    /// G1(0.9) = 1.6; the others sit at their factor's minimum 0.99.
    const X0: [f64; 4] = [0.9, 0.5, 0.5, 0.5];

    #[test]
    fn fixing_the_significant_parameter_keeps_the_output_close() {
        let m = model();
        let x0 = X0;
        let keep = vec!["x1".to_string()];
        let v = validate(&m, &keep, &x0, 2000, 4, &|_| {}).expect("runs");
        assert_eq!(v.random, ["x2", "x3", "x4"]);
        assert_eq!(v.headline, ConformityKind::Relative);
        // Each non-significant factor (|4x − 2| + 99)/100 lies in [0.99, 1.01],
        // 0.99 at the reference, so |Δy/y| ≤ (1.01/0.99)³ − 1.
        let bound = 1.0 - ((1.01f64 / 0.99).powi(3) - 1.0);
        assert!(v.min >= bound && v.min < 1.0, "{v:?}");
        // E[factor] = 1, so E[y/y₀] = 1/0.99³ and y ≥ y₀ always: the mean
        // conformity is 1 − (1/0.99³ − 1) = 0.96940.
        assert!((v.mean - (2.0 - 0.99f64.powi(-3))).abs() < 2e-3, "{v:?}");
    }

    #[test]
    fn randomizing_the_significant_parameter_is_detected() {
        let m = model();
        let x0 = X0;
        let keep: Vec<String> = ["x2", "x3", "x4"].iter().map(|s| s.to_string()).collect();
        let v = validate(&m, &keep, &x0, 2000, 4, &|_| {}).expect("runs");
        // G1(x1) = |4 x1 − 2| spans [0, 2] around G1(0.9) = 1.6: conformity collapses.
        assert!(v.min < 0.05, "{v:?}");
    }

    #[test]
    fn identical_for_one_and_two_threads_and_named_errors() {
        let m = model();
        let x0 = X0;
        let keep = vec!["x1".to_string()];
        let on = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .expect("pool")
                .install(|| validate(&m, &keep, &x0, 700, 9, &|_| {}).expect("runs"))
        };
        assert_eq!(on(1), on(2));
        let bad = vec!["x9".to_string()];
        let e = validate(&m, &bad, &x0, 10, 1, &|_| {}).unwrap_err();
        assert!(e.to_string().contains("x9"), "{e}");
    }

    #[test]
    fn conformity_kinds() {
        assert_eq!(
            ConformityKind::of("p0.mode1.mac"),
            ConformityKind::Criterion
        );
        assert_eq!(
            ConformityKind::of("p3.band2.csf"),
            ConformityKind::Criterion
        );
        assert_eq!(
            ConformityKind::of("p0.mode1.frequency"),
            ConformityKind::Relative
        );
        assert_eq!(ConformityKind::Relative.conformity(99.0, 100.0), 0.99);
        assert_eq!(ConformityKind::Relative.conformity(300.0, 100.0), 0.0);
        assert_eq!(ConformityKind::Criterion.conformity(0.7, 1.0), 0.7);
    }
}
