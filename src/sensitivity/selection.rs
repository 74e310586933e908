//! A threshold rule checked by PUB2's own validation (issue 26; seed
//! section 5.2.1): keep the parameters in the order of their combined total
//! index and grow the kept set until the Monte Carlo validation of the split
//! ([`super::validation`]) reaches a target minimum conformity (PUB2: 89 %).
//!
//! PUB2 chose its threshold on the combined index and then showed, by the
//! Monte Carlo experiment, that the minimum conformity of the outputs stays
//! above 89 %. A fixed threshold does not carry over from one model to
//! another (the index of a parameter that rules a few outputs among many is
//! small in the mean); the validation is the criterion PUB2 judged a split
//! by, so here it picks the cut: with the parameters ranked by their
//! combined index c_(1) ≥ c_(2) ≥ …, the kept set is the shortest prefix
//! {(1), …, (k)}, k ≥ k₀ (the threshold's set), whose validation's minimum
//! headline conformity (MAC, FRAC, CSF; else 1 − |y − y₀|/|y₀|, eq. 2.64)
//! reaches the target. The threshold actually applied is c_(k).
//!
//! The prefix is found by doubling (k₀, k₀+1, k₀+3, k₀+7, …) and then
//! bisection, on one set of random draws for every probe (common random
//! numbers, [`super::validation`]): the minimum conformity grows with k up
//! to sampling noise, which the common draws largely remove. A probe stops
//! at the first batch whose minimum falls below the target, so failing
//! probes are cheap. The probes' stream should differ from the stream of
//! the validation finally reported, which then checks the cut on fresh
//! samples.
//!
//! [`select_guided`] grows the set instead by the failing output: after a
//! probe fails, it adds the dropped parameter with the largest total index
//! for the output whose conformity fell lowest (that output's own PUB2
//! subproblem, which a small weighted-mean index can hide).

use super::validation::{check, draw_units, headline_kind, points, ConformityKind};
use super::SensitivityError;
use crate::simulator::{evaluate_all, Model};
use serde::Serialize;

/// Samples per batch of a probe (a failing probe stops after its batch).
const BATCH: usize = 64;

/// One validation of a prefix of the ranking.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Probe {
    /// Parameters kept (the first `kept` of the ranking).
    pub kept: usize,
    /// Least headline conformity over the samples evaluated.
    pub min: f64,
    /// Samples evaluated (fewer than asked when the probe failed early).
    pub samples: usize,
    /// The headline output with the least conformity.
    pub worst: String,
    pub passed: bool,
}

/// The kept set the rule chose and how it was found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Selection {
    pub target: f64,
    /// Samples per probe and the seed of their draws.
    pub samples: usize,
    pub seed: u64,
    /// The threshold's own set size k₀.
    pub start: usize,
    /// The kept parameters, in ranking order.
    pub kept: Vec<String>,
    /// Whether some prefix reached the target (otherwise every ranked
    /// parameter is kept).
    pub passed: bool,
    /// The probes in the order they ran.
    pub probes: Vec<Probe>,
    /// Model evaluations spent.
    pub evaluations: usize,
}

/// What both selections start from: the arguments checked, the seeded
/// unit draws shared by every probe and the outputs at the reference point.
fn prepare(
    model: &(impl Model + ?Sized),
    ranked: &[String],
    start: usize,
    reference: &[f64],
    target: f64,
    samples: usize,
    seed: u64,
) -> Result<(Vec<Vec<f64>>, Vec<f64>), SensitivityError> {
    check(model, ranked, reference)?;
    if samples == 0 || start > ranked.len() || !(target.is_finite()) {
        return Err(SensitivityError::Invalid(format!(
            "selection needs samples > 0 (got {samples}), a start within the {} ranked parameters (got {start}) and a finite target (got {target})",
            ranked.len()
        )));
    }
    let units = draw_units(samples, model.parameters().len(), seed);
    let y0 = evaluate_all(model, &[reference.to_vec()], 1, &|_| {})?
        .pop()
        .ok_or_else(|| SensitivityError::Invalid("the model returned no outputs".into()))?;
    Ok((units, y0))
}

/// Grow the kept set from the first `start` of `ranked` (parameter names in
/// decreasing order of their combined index) until the validation's minimum
/// conformity reaches `target`, `samples` random points per probe drawn
/// from `seed`; `reference` holds every model parameter's value at the
/// reference point, in model order.
#[allow(clippy::too_many_arguments)]
pub fn select_by_validation(
    model: &(impl Model + ?Sized),
    ranked: &[String],
    start: usize,
    reference: &[f64],
    target: f64,
    samples: usize,
    seed: u64,
    progress: &dyn Fn(u64),
) -> Result<Selection, SensitivityError> {
    let (units, y0) = prepare(model, ranked, start, reference, target, samples, seed)?;
    let mut probes: Vec<Probe> = Vec::new();
    let mut probe = |k: usize| -> Result<bool, SensitivityError> {
        let p = run_probe(
            model,
            &ranked[..k],
            reference,
            &y0,
            &units,
            target,
            progress,
        )?;
        let passed = p.passed;
        probes.push(p);
        Ok(passed)
    };
    // Doubling: the last failing and the first passing prefix.
    let (mut fail, mut pass) = (None, None);
    let (mut k, mut step) = (start, 1);
    loop {
        if probe(k)? {
            pass = Some(k);
            break;
        }
        fail = Some(k);
        if k == ranked.len() {
            break;
        }
        k = (k + step).min(ranked.len());
        step *= 2;
    }
    // Bisection between them.
    if let (Some(mut lo), Some(mut hi)) = (fail, pass) {
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if probe(mid)? {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        pass = Some(hi);
    }
    let evaluations = probes.iter().map(|p| p.samples).sum::<usize>() + 1;
    Ok(Selection {
        target,
        samples,
        seed,
        start,
        kept: ranked[..pass.unwrap_or(ranked.len())].to_vec(),
        passed: pass.is_some(),
        probes,
        evaluations,
    })
}

/// How [`select_guided`] picks the next parameter after a failing probe.
pub struct Influence<'a> {
    /// The order of every vector in `total`.
    pub parameters: &'a [String],
    /// Per analyzed output: its total indices ST (eq. 2.12).
    pub total: &'a [(String, Vec<f64>)],
}

/// As [`select_by_validation`], but each failing probe adds the one
/// parameter that the output with the least conformity depends on most:
/// the dropped parameter with the largest total index ST for that output
/// (its PUB2 subproblem's leader), or the next in the ranking when the
/// output was not analyzed. Each probe adds one parameter, so at most
/// d − k₀ + 1 probes run; the kept set need not be a prefix of the ranking.
#[allow(clippy::too_many_arguments)]
pub fn select_guided(
    model: &(impl Model + ?Sized),
    ranked: &[String],
    influence: &Influence,
    start: usize,
    reference: &[f64],
    target: f64,
    samples: usize,
    seed: u64,
    progress: &dyn Fn(u64),
) -> Result<Selection, SensitivityError> {
    let (units, y0) = prepare(model, ranked, start, reference, target, samples, seed)?;
    let mut kept: Vec<String> = ranked[..start].to_vec();
    let mut probes = Vec::new();
    let passed = loop {
        let p = run_probe(model, &kept, reference, &y0, &units, target, progress)?;
        let (passed, worst) = (p.passed, p.worst.clone());
        probes.push(p);
        if passed {
            break true;
        }
        let leader = influence
            .total
            .iter()
            .find(|(o, _)| *o == worst)
            .and_then(|(_, st)| {
                influence
                    .parameters
                    .iter()
                    .zip(st)
                    .filter(|(n, _)| ranked.contains(n) && !kept.contains(n))
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .map(|(n, _)| n.clone())
            });
        match leader.or_else(|| ranked.iter().find(|n| !kept.contains(n)).cloned()) {
            Some(next) => kept.push(next),
            None => break false,
        }
    };
    let evaluations = probes.iter().map(|p| p.samples).sum::<usize>() + 1;
    Ok(Selection {
        target,
        samples,
        seed,
        start,
        kept,
        passed,
        probes,
        evaluations,
    })
}

/// Validate the split `fixed` on the draws `units` batch by batch, stopping
/// at the first batch whose least headline conformity is below `target`.
fn run_probe(
    model: &(impl Model + ?Sized),
    fixed: &[String],
    reference: &[f64],
    y0: &[f64],
    units: &[Vec<f64>],
    target: f64,
    progress: &dyn Fn(u64),
) -> Result<Probe, SensitivityError> {
    let is_fixed = check(model, fixed, reference)?;
    let names = model.outputs();
    let headline = headline_kind(names);
    let kinds: Vec<ConformityKind> = names.iter().map(|n| ConformityKind::of(n)).collect();
    let (mut min, mut worst, mut samples) = (f64::INFINITY, String::new(), 0);
    for batch in units.chunks(BATCH) {
        let ys = evaluate_all(
            model,
            &points(model, reference, &is_fixed, batch),
            BATCH,
            progress,
        )?;
        samples += ys.len();
        for y in &ys {
            for (o, kind) in kinds.iter().enumerate() {
                let c = kind.conformity(y[o], y0[o]);
                if *kind == headline && c < min {
                    min = c;
                    worst.clone_from(&names[o]);
                }
            }
        }
        if min < target {
            break;
        }
    }
    Ok(Probe {
        kept: fixed.len(),
        min,
        samples,
        worst,
        passed: min >= target,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::SobolG;

    /// G = Π gᵢ, gᵢ = (|4xᵢ − 2| + aᵢ)/(1 + aᵢ); at xᵢ = 0.25 every gᵢ = 1.
    /// With the set R random, y/y₀ = Π_{i∈R} gᵢ ∈ [Π aᵢ/(1+aᵢ), Π (2+aᵢ)/(1+aᵢ)].
    #[test]
    fn the_shortest_passing_prefix_is_found() {
        let m = SobolG::new(vec![0.0, 1.0, 9.0, 99.0, 99.0, 99.0]).expect("valid a");
        let ranked: Vec<String> = (1..=6).map(|i| format!("x{i}")).collect();
        let x0 = [0.25; 6];
        // Keeping x1..x3: |y/y₀ − 1| ≤ (101/100)³ − 1 = 0.0303, conformity ≥ 0.9697;
        // with x3 random, g₃ spans [0.9, 1.1] and half the samples leave ±5 %.
        let s = select_by_validation(&m, &ranked, 1, &x0, 0.95, 500, 7, &|_| {}).expect("runs");
        assert!(s.passed);
        assert_eq!(s.kept, ["x1", "x2", "x3"], "{s:?}");
        // Probes: 1 (fail), 2 (fail), 4 (pass), then 3 (pass).
        let ks: Vec<usize> = s.probes.iter().map(|p| p.kept).collect();
        assert_eq!(ks, [1, 2, 4, 3]);
        // Failing probes stop after their first batch.
        assert!(s.probes[0].samples == BATCH && s.probes[1].samples == BATCH);
        assert_eq!(s.probes[3].samples, 500);
        // Guided by the worst output: y has the indices of G, so the order
        // is the same here, one parameter per probe: 1, 2, 3 (pass).
        let st = vec![("y".to_string(), vec![0.8, 0.2, 0.05, 0.01, 1e-4, 1e-4])];
        let influence = Influence {
            parameters: &ranked,
            total: &st,
        };
        let g = select_guided(&m, &ranked, &influence, 1, &x0, 0.95, 500, 7, &|_| {});
        let g = g.expect("runs");
        assert_eq!(g.kept, ["x1", "x2", "x3"]);
        let ks: Vec<usize> = g.probes.iter().map(|p| p.kept).collect();
        assert_eq!(ks, [1, 2, 3]);
        // A start that already passes is kept as it is.
        let s = select_by_validation(&m, &ranked, 4, &x0, 0.95, 100, 7, &|_| {}).expect("runs");
        assert_eq!(s.kept.len(), 4);
        assert_eq!(s.probes.len(), 1);
    }

    #[test]
    fn identical_for_one_and_two_threads() {
        let m = SobolG::new(vec![0.0, 1.0, 9.0, 99.0, 99.0, 99.0]).expect("valid a");
        let ranked: Vec<String> = (1..=6).map(|i| format!("x{i}")).collect();
        let x0 = [0.3; 6];
        let st = vec![("y".to_string(), vec![0.8, 0.2, 0.05, 0.01, 1e-4, 1e-4])];
        let on = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .expect("pool")
                .install(|| {
                    let influence = Influence {
                        parameters: &ranked,
                        total: &st,
                    };
                    let a = select_by_validation(&m, &ranked, 0, &x0, 0.9, 300, 3, &|_| {});
                    let b = select_guided(&m, &ranked, &influence, 0, &x0, 0.9, 300, 3, &|_| {});
                    (a.expect("runs"), b.expect("runs"))
                })
        };
        assert_eq!(on(1), on(2));
    }
}
