//! The sensitivity-guided strategy (PUB3, seed section 5.2.3): the global
//! problem is split into the per-output subproblems of a GSA screening
//! (PUB2: per output, its significant parameters).
//!
//! 1. Per subproblem, only its significant STIFFNESS parameters are
//!    optimized, by SLSQP on that output's own criterion — NFD for
//!    `p{i}.mode{r}.frequency`, 1 − MAC for `.mac`
//!    (the unpaired penalty of [`super::objective`] when the mode is lost;
//!    damping outputs are skipped: they also depend on the random damping) —
//!    with every other parameter at a seeded random value within its bounds.
//!    This is repeated `repeats` times with different random values and
//!    start points.
//! 2. A parameter's spread over the repeats measures how well its subproblem
//!    determines it: the coefficient of variation in its scale — std/mean of
//!    the values for linear parameters, std of ln(value) for log parameters
//!    (equal to the CV to first order). Each stiffness parameter takes its
//!    value (the mean in its scale: arithmetic or geometric) from the
//!    subproblem in which it varied least. Stiffness parameters in no
//!    subproblem keep the model file's value.
//! 3. The damping parameters are fitted by bounded linear least squares at
//!    the identified stiffness ([`super::damping`]).
//!
//! Deviation from PUB3, which identifies the stiffness from the mode-shape
//! (MAC) subproblems only: every subproblem with a stiffness parameter is
//! used here (frequency ones too), because 1 − MAC is blind to a common
//! scale of all stiffnesses and a reference may have few measured DOFs.
//!
//! The budget is split evenly over the subproblem runs (SLSQP stops early
//! when converged); the damping fit and the final J cost a few more.

use super::{identify_damping, IdentifyError, ModalObjective, Term};
use crate::dynamics::{ParameterKind, Scale};
use crate::optimize::slsqp::{self, SlsqpParams};
use crate::optimize::{Bounds, OptimizeResult, Problem};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

/// One subproblem of a GSA screening (an entry of subproblems.json).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
pub struct SubproblemSpec {
    pub output: String,
    pub parameters: Vec<String>,
}

/// What one subproblem found.
#[derive(Clone, Debug, Serialize)]
pub struct SubproblemRun {
    pub output: String,
    /// The stiffness parameters optimized.
    pub parameters: Vec<String>,
    /// Per repeat: the values found (in `parameters` order) and the criterion.
    pub values: Vec<Vec<f64>>,
    pub objectives: Vec<f64>,
    /// Per parameter: mean in its scale and coefficient of variation.
    pub mean: Vec<f64>,
    pub cv: Vec<f64>,
    pub evaluations: usize,
    /// Why the output is not used (no stiffness parameter), if so.
    pub skipped: Option<String>,
}

/// The result of the guided strategy.
#[derive(Clone, Debug, Serialize)]
pub struct GuidedResult {
    pub x: Vec<f64>,
    pub objective: f64,
    pub evaluations: usize,
    pub subproblems: Vec<SubproblemRun>,
    /// Per stiffness parameter: the subproblem output it was taken from.
    pub chosen_from: Vec<(String, Option<String>)>,
    /// Best-so-far of every subproblem run, one after another
    /// (evaluation, criterion value).
    pub history: Vec<(usize, f64)>,
    pub damping_equations: usize,
    pub damping_rms_residual: f64,
}

/// Parse `p{index}.mode{r}.{frequency|damping|mac}` into (slot, mode, term).
fn parse_output(o: &ModalObjective, name: &str) -> Result<(usize, usize, Term), IdentifyError> {
    let bad = || {
        IdentifyError::Invalid(format!(
            "subproblem output `{name}` is not `p<position>.mode<r>.<frequency|damping|mac>`; the sensitivity input must come from a gsa stage on this model file"
        ))
    };
    let mut parts = name.split('.');
    let (Some(p), Some(m), Some(q), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad());
    };
    let index: u32 = p
        .strip_prefix('p')
        .and_then(|s| s.parse().ok())
        .ok_or_else(bad)?;
    let mode: usize = m
        .strip_prefix("mode")
        .and_then(|s| s.parse().ok())
        .ok_or_else(bad)?;
    let term = match q {
        "frequency" => Term::Nfd,
        "damping" => Term::Ndd,
        "mac" => Term::Mac,
        _ => return Err(bad()),
    };
    let slot = o.slot(index).ok_or_else(|| {
        IdentifyError::Invalid(format!(
            "subproblem output `{name}`: position {index} is not in the reference (or not selected by `positions`)"
        ))
    })?;
    if mode == 0 || mode > o.matches(&o.nominal())?[slot].len() {
        return Err(IdentifyError::Invalid(format!(
            "subproblem output `{name}`: the reference has no mode {mode} at position {index}"
        )));
    }
    Ok((slot, mode - 1, term))
}

/// Mean in the parameter's scale and the coefficient of variation.
fn spread(values: &[f64], scale: Scale) -> (f64, f64) {
    let n = values.len() as f64;
    match scale {
        Scale::Log => {
            let l: Vec<f64> = values.iter().map(|v| v.ln()).collect();
            let m = l.iter().sum::<f64>() / n;
            let var = l.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
            (m.exp(), var.sqrt())
        }
        Scale::Linear => {
            let m = values.iter().sum::<f64>() / n;
            let var = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
            (m, var.sqrt() / m.abs().max(f64::MIN_POSITIVE))
        }
    }
}

/// Run the guided strategy with `repeats` starts per subproblem and at most
/// about `budget` evaluations; `progress` gets the size of every batch.
pub fn guided(
    objective: &ModalObjective,
    subproblems: &[SubproblemSpec],
    settings: &SlsqpParams,
    budget: usize,
    repeats: usize,
    seed: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<GuidedResult, IdentifyError> {
    let params = objective.parameters();
    let full = objective.bounds()?;
    let nominal = objective.nominal();
    let stiff = |name: &str| {
        params
            .iter()
            .position(|p| p.name == name && p.kind == ParameterKind::Stiffness)
    };
    let active = subproblems
        .iter()
        .filter(|s| !s.output.ends_with(".damping"))
        .filter(|s| s.parameters.iter().any(|p| stiff(p).is_some()))
        .count();
    let runs_total = (active * repeats).max(1);
    let per_run = (budget / runs_total).max(1);
    let mut runs = Vec::new();
    let mut history = Vec::new();
    let mut evaluations = 0;
    for (s_index, s) in subproblems.iter().enumerate() {
        let idx: Vec<usize> = s.parameters.iter().filter_map(|p| stiff(p)).collect();
        let names: Vec<String> = idx.iter().map(|&i| params[i].name.clone()).collect();
        let mut run = SubproblemRun {
            output: s.output.clone(),
            parameters: names,
            values: Vec::new(),
            objectives: Vec::new(),
            mean: Vec::new(),
            cv: Vec::new(),
            evaluations: 0,
            skipped: None,
        };
        if idx.is_empty() {
            run.skipped = Some("no significant stiffness parameter".into());
            runs.push(run);
            continue;
        }
        let (slot, mode, term) = parse_output(objective, &s.output)?;
        if term == Term::Ndd {
            // A damping ratio depends on the (random) damping values too, so
            // it cannot pin a stiffness; damping comes from step 3.
            run.skipped = Some("damping output: used by the damping fit only".into());
            runs.push(run);
            continue;
        }
        let bounds = Bounds::new(
            idx.iter().map(|&i| full.lower()[i]).collect(),
            idx.iter().map(|&i| full.upper()[i]).collect(),
            idx.iter().map(|&i| full.scale()[i]).collect(),
        )
        .map_err(|e| IdentifyError::Invalid(e.to_string()))?;
        for k in 0..repeats {
            // One stream per (subproblem, repeat): reproducible and independent
            // of how many subproblems come before.
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ ((s_index as u64) << 32 | k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let u: Vec<f64> = (0..params.len()).map(|_| rng.random::<f64>()).collect();
            let others = full.to_physical(&u);
            let u0: Vec<f64> = (0..idx.len()).map(|_| rng.random::<f64>()).collect();
            let x0 = bounds.to_physical(&u0);
            let point = |sub: &[f64]| {
                let mut x = others.clone();
                for (j, &i) in idx.iter().enumerate() {
                    x[i] = sub[j];
                }
                x
            };
            let batch = |points: &[Vec<f64>]| -> Vec<f64> {
                let v: Vec<f64> = points
                    .par_iter()
                    .map(|sub| match objective.matches(&point(sub)) {
                        Ok(all) => objective.term(slot, mode, all[slot][mode], Some(term)),
                        Err(_) => f64::INFINITY,
                    })
                    .collect();
                progress(points.len() as u64);
                v
            };
            let problem = Problem::new(bounds.clone(), &batch, per_run);
            let r: OptimizeResult = slsqp::minimize(&problem, settings, &x0)?;
            for h in &r.history {
                history.push((evaluations + h.evaluation, h.f_best));
            }
            evaluations += r.evaluations;
            run.evaluations += r.evaluations;
            run.values.push(r.x_best);
            run.objectives.push(r.f_best);
        }
        for (j, &i) in idx.iter().enumerate() {
            let v: Vec<f64> = run.values.iter().map(|x| x[j]).collect();
            let (m, cv) = spread(&v, params[i].scale);
            run.mean.push(m);
            run.cv.push(cv);
        }
        runs.push(run);
    }
    let mut x = nominal.clone();
    let mut chosen_from = Vec::new();
    for (i, p) in params.iter().enumerate() {
        if p.kind != ParameterKind::Stiffness {
            continue;
        }
        let best = runs
            .iter()
            .filter_map(|r| {
                let j = r.parameters.iter().position(|n| *n == p.name)?;
                r.cv.get(j).map(|cv| (r, j, *cv))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2));
        match best {
            Some((r, j, _)) => {
                x[i] = r.mean[j];
                chosen_from.push((p.name.clone(), Some(r.output.clone())));
            }
            None => chosen_from.push((p.name.clone(), None)),
        }
    }
    let damping: Vec<usize> = (0..params.len())
        .filter(|&i| params[i].kind == ParameterKind::Damping)
        .collect();
    let (mut eq, mut rms) = (0, 0.0);
    if !damping.is_empty() {
        let fit = identify_damping(objective, &x, &damping)?;
        progress(fit.evaluations as u64);
        evaluations += fit.evaluations;
        x = fit.x;
        eq = fit.equations;
        rms = fit.rms_residual;
    }
    let j = objective.cost(&x);
    progress(1);
    evaluations += 1;
    Ok(GuidedResult {
        x,
        objective: j,
        evaluations,
        subproblems: runs,
        chosen_from,
        history,
        damping_equations: eq,
        damping_rms_residual: rms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::black_box::tests::{objective, truth};

    #[test]
    fn spread_is_the_cv_in_the_parameter_scale() {
        let (m, cv) = spread(&[1.0, 3.0], Scale::Linear);
        assert!((m - 2.0).abs() < 1e-15 && (cv - 0.5).abs() < 1e-15);
        let (m, cv) = spread(&[10.0, 1000.0], Scale::Log);
        assert!((m - 100.0).abs() < 1e-9 && (cv - 100f64.ln() / 2.0).abs() < 1e-12);
    }

    #[test]
    fn guided_takes_each_stiffness_from_its_least_varying_subproblem() {
        let o = objective();
        let subs = vec![
            SubproblemSpec {
                output: "p0.mode1.frequency".into(),
                parameters: vec!["k1.k_x".into(), "k12.k_x".into()],
            },
            SubproblemSpec {
                output: "p0.mode3.frequency".into(),
                parameters: vec!["k1.k_x".into()],
            },
            SubproblemSpec {
                output: "p0.mode1.damping".into(),
                parameters: vec!["k1.c_x".into()],
            },
        ];
        let r = guided(&o, &subs, &SlsqpParams::default(), 1200, 3, 5, &|_| {}).unwrap();
        assert_eq!(r.subproblems.len(), 3);
        assert!(r.subproblems[2].skipped.is_some());
        let (a, b) = (&r.subproblems[0], &r.subproblems[1]);
        assert_eq!(a.values.len(), 3);
        assert!(a.objectives.iter().all(|v| v.is_finite()));
        // k1 comes from the subproblem where its CV is smaller.
        let from = if a.cv[0] <= b.cv[0] { a } else { b };
        assert_eq!(r.chosen_from[0].1.as_deref(), Some(from.output.as_str()));
        let k1 = r.x[0];
        assert!((k1 - from.mean[0]).abs() <= 1e-12 * k1);
        // k12 only in the first; k23, k3 in none → nominal.
        assert_eq!(r.chosen_from[1].1.as_deref(), Some("p0.mode1.frequency"));
        assert_eq!((r.x[2], r.x[3]), (o.nominal()[2], o.nominal()[3]));
        // Budget: split over 6 runs, plus the damping fit and the final J.
        assert!(r.evaluations <= 1200 + 4 + 2, "{}", r.evaluations);
        // Same seed → same result.
        let again = guided(&o, &subs, &SlsqpParams::default(), 1200, 3, 5, &|_| {}).unwrap();
        assert_eq!(again.x, r.x);
        let _ = truth();
    }

    #[test]
    fn a_foreign_output_name_is_rejected() {
        let o = objective();
        let subs = vec![SubproblemSpec {
            output: "y1".into(),
            parameters: vec!["k1.k_x".into()],
        }];
        let e = guided(&o, &subs, &SlsqpParams::default(), 100, 1, 0, &|_| {}).unwrap_err();
        assert!(e.to_string().contains("p<position>.mode<r>"), "{e}");
    }
}
