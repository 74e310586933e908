//! Combining Sobol total indices over many outputs into one screening (PUB2,
//! seed section 5.2.1): a weighted mean of each parameter's total index over
//! the outputs, compared with a threshold, splits the parameters into
//! significant and non-significant ones; per output, the parameters whose
//! own total index reaches the threshold form an identification subproblem.
//!
//! combined_i = Σ_o w_o ST_{o,i} / Σ_o w_o;  significant ⇔ combined_i ≥ threshold.
//!
//! The weighted mean is PUB2's rule. It can overlook a parameter that rules
//! one or two outputs among hundreds; [`Combine::Max`] instead takes
//! max_o w_o ST_{o,i} / max_o w_o, so a parameter is significant as soon as
//! it is in some output's subproblem (the union of the subproblems).

#![allow(non_snake_case)]

use super::SensitivityError;
use serde::Serialize;

/// The significant parameters of one output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Subproblem {
    pub output: String,
    /// Significant for this output, in parameter order.
    pub parameters: Vec<String>,
}

/// The result of the screening (serialized as `subproblems.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Screening {
    /// Per output: its significant parameters.
    pub subproblems: Vec<Subproblem>,
    /// Significant by the weighted combination, in parameter order.
    pub significant: Vec<String>,
    pub non_significant: Vec<String>,
    /// Weighted mean total index per parameter, in parameter order.
    pub combined_ST: Vec<(String, f64)>,
    /// Weight of every output as given (before normalization).
    pub weights: Vec<(String, f64)>,
    pub threshold: f64,
    pub rule: Combine,
}

/// How total indices are combined over the outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Combine {
    /// Weighted mean (PUB2).
    #[default]
    Mean,
    /// Weighted maximum: significant for the screening if significant for
    /// any output.
    Max,
}

/// Screen `parameters` by the total indices `ST[o]` of each output `outputs[o]`
/// with output weights `weights` (same order as `outputs`; all ≥ 0, not all 0).
pub fn aggregate(
    parameters: &[String],
    outputs: &[String],
    ST: &[Vec<f64>],
    weights: &[f64],
    threshold: f64,
    rule: Combine,
) -> Result<Screening, SensitivityError> {
    if outputs.is_empty() || ST.len() != outputs.len() || weights.len() != outputs.len() {
        return Err(SensitivityError::Invalid(format!(
            "{} outputs, {} index sets and {} weights: give one weight and one index set per output",
            outputs.len(),
            ST.len(),
            weights.len()
        )));
    }
    if let Some(o) = ST.iter().position(|s| s.len() != parameters.len()) {
        return Err(SensitivityError::Invalid(format!(
            "output `{}` has {} indices for {} parameters",
            outputs[o],
            ST[o].len(),
            parameters.len()
        )));
    }
    if let Some(w) = weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
        return Err(SensitivityError::Invalid(format!(
            "weight {w} is not a finite number >= 0"
        )));
    }
    let total: f64 = weights.iter().sum();
    if total <= 0.0 {
        return Err(SensitivityError::Invalid(
            "all output weights are 0; give at least one output a positive weight".into(),
        ));
    }
    if !threshold.is_finite() {
        return Err(SensitivityError::Invalid(
            "the threshold must be a finite number".into(),
        ));
    }
    let combined = combine(parameters.len(), ST, weights, rule);
    let (mut significant, mut non_significant) = (Vec::new(), Vec::new());
    for (name, c) in parameters.iter().zip(&combined) {
        if *c >= threshold {
            significant.push(name.clone());
        } else {
            non_significant.push(name.clone());
        }
    }
    let subproblems = outputs
        .iter()
        .zip(ST)
        .map(|(o, s)| Subproblem {
            output: o.clone(),
            parameters: parameters
                .iter()
                .zip(s)
                .filter(|(_, v)| **v >= threshold)
                .map(|(p, _)| p.clone())
                .collect(),
        })
        .collect();
    Ok(Screening {
        subproblems,
        significant,
        non_significant,
        combined_ST: parameters.iter().cloned().zip(combined).collect(),
        weights: outputs
            .iter()
            .cloned()
            .zip(weights.iter().copied())
            .collect(),
        threshold,
        rule,
    })
}

/// The combined index of each of `d` parameters from the per-output indices
/// `ST[o][i]` (weights already checked: finite, ≥ 0, positive sum):
/// Σ_o w_o ST_{o,i} / Σ_o w_o (mean) or max_o w_o ST_{o,i} / max_o w_o (max).
/// Also applied to each bootstrap resample of the indices
/// ([`super::adequacy::score_intervals`]).
pub fn combine<S: AsRef<[f64]>>(d: usize, ST: &[S], weights: &[f64], rule: Combine) -> Vec<f64> {
    let total: f64 = weights.iter().sum();
    let heaviest = weights.iter().copied().fold(0.0, f64::max);
    (0..d)
        .map(|i| {
            let weighted = ST
                .iter()
                .zip(weights)
                .map(|(s, w)| w * s.as_ref().get(i).copied().unwrap_or(f64::NAN));
            match rule {
                Combine::Mean => weighted.sum::<f64>() / total,
                Combine::Max => weighted.fold(f64::NEG_INFINITY, f64::max) / heaviest,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn weighted_combination_and_subproblems() {
        let params = names(&["k1", "k2", "c1"]);
        let outputs = names(&["f1", "f2"]);
        let ST = vec![vec![0.9, 0.05, 0.01], vec![0.0, 0.3, 0.02]];
        let s = aggregate(&params, &outputs, &ST, &[1.0, 3.0], 0.1, Combine::Mean).unwrap();
        // combined = [(0.9 + 0)/4, (0.05 + 0.9)/4, (0.01 + 0.06)/4]
        let c: Vec<f64> = s.combined_ST.iter().map(|(_, v)| *v).collect();
        for (a, b) in c.iter().zip([0.225, 0.2375, 0.0175]) {
            assert!((a - b).abs() < 1e-15);
        }
        assert_eq!(s.significant, names(&["k1", "k2"]));
        assert_eq!(s.non_significant, names(&["c1"]));
        assert_eq!(s.subproblems[0].parameters, names(&["k1"]));
        assert_eq!(s.subproblems[1].parameters, names(&["k2"]));
        // With the weight on f1 only, k2 drops out.
        let s = aggregate(&params, &outputs, &ST, &[1.0, 0.0], 0.1, Combine::Mean).unwrap();
        assert_eq!(s.significant, names(&["k1"]));
        // The maximum rule: c1 (0.02 at most) stays out, k2 (0.3 · 3 / 3) is in.
        let s = aggregate(&params, &outputs, &ST, &[1.0, 3.0], 0.1, Combine::Max).unwrap();
        let c: Vec<f64> = s.combined_ST.iter().map(|(_, v)| *v).collect();
        assert_eq!(c, [0.3, 0.3, 0.02]);
        assert_eq!(s.significant, names(&["k1", "k2"]));
    }

    #[test]
    fn bad_weights_are_rejected() {
        let p = names(&["a"]);
        let o = names(&["y"]);
        assert!(aggregate(&p, &o, &[vec![0.5]], &[0.0], 0.1, Combine::Mean).is_err());
        assert!(aggregate(&p, &o, &[vec![0.5]], &[-1.0], 0.1, Combine::Mean).is_err());
        assert!(aggregate(&p, &o, &[vec![0.5]], &[1.0, 1.0], 0.1, Combine::Mean).is_err());
        assert!(aggregate(&p, &o, &[vec![0.5, 0.1]], &[1.0], 0.1, Combine::Mean).is_err());
    }
}
