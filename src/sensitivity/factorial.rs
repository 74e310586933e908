//! Full factorial designs run on a model, analyzed by ANOVA (seed section
//! 2.1.1; PUB1 varied the preload of the ball screw drive and of the linear
//! guides in levels and asked which modal parameters respond to which).
//!
//! Every combination of the factor levels is one run (the first factor
//! varies slowest); parameters that are not factors stay at their nominal
//! values. The runs are evaluated as one parallel batch, then each selected
//! output gets its own ANOVA table. A deterministic model has no replicate
//! scatter, so the residual is the highest interaction left out of the
//! table: use `interactions: 1` for two factors, or three or more factors.

use super::{anova, AnovaRow, Design, Factor, SensitivityError};
use crate::parameter::nominal;
use crate::simulator::{evaluate_all, Model};

/// The design and its results.
#[derive(Clone, Debug)]
pub struct FactorialResult {
    /// Factor names, in design order.
    pub factors: Vec<String>,
    /// Per run: the factor values.
    pub runs: Vec<Vec<f64>>,
    /// Analyzed output names.
    pub outputs: Vec<String>,
    /// Per run: the analyzed outputs.
    pub responses: Vec<Vec<f64>>,
    /// Per analyzed output: its ANOVA table.
    pub tables: Vec<Vec<AnovaRow>>,
}

/// Run the full factorial of `levels` (parameter name → values) on `model`
/// and analyze `outputs` (names; empty = all) with `interactions` (1 or 2).
pub fn factorial_anova(
    model: &(impl Model + ?Sized),
    levels: &[(String, Vec<f64>)],
    outputs: &[String],
    interactions: u8,
    progress: &dyn Fn(u64),
) -> Result<FactorialResult, SensitivityError> {
    let params = model.parameters();
    let known = || params.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
    let mut index = Vec::with_capacity(levels.len());
    for (name, values) in levels {
        let i = params.iter().position(|p| &p.name == name).ok_or_else(|| {
            SensitivityError::UnknownParameter {
                name: name.clone(),
                known: known(),
            }
        })?;
        if let Some(v) = values.iter().find(|v| !params[i].contains(**v)) {
            return Err(SensitivityError::Invalid(format!(
                "level {v} of `{name}` lies outside its bounds [{}, {}]",
                params[i].lower, params[i].upper
            )));
        }
        index.push(i);
    }
    let names = model.outputs();
    let selected = super::select_outputs(names, outputs)?;

    // Level codes of every run, first factor slowest.
    let total: usize = levels.iter().map(|(_, v)| v.len()).product();
    let codes: Vec<Vec<usize>> = (0..total)
        .map(|mut r| {
            let mut c = vec![0; levels.len()];
            for (f, (_, v)) in levels.iter().enumerate().rev() {
                c[f] = r % v.len();
                r /= v.len();
            }
            c
        })
        .collect();
    let x0 = nominal(params);
    let points: Vec<Vec<f64>> = codes
        .iter()
        .map(|c| {
            let mut x = x0.clone();
            for (f, &i) in index.iter().enumerate() {
                x[i] = levels[f].1[c[f]];
            }
            x
        })
        .collect();
    let ys = evaluate_all(model, &points, 64, progress)?;

    let factors: Vec<Factor> = levels
        .iter()
        .enumerate()
        .map(|(f, (name, values))| {
            let labels: Vec<String> = codes.iter().map(|c| format!("{}", values[c[f]])).collect();
            Factor::from_labels(name.clone(), &labels)
        })
        .collect();
    let mut tables = Vec::with_capacity(selected.len());
    for &o in &selected {
        let design = Design {
            factors: factors.clone(),
            response: ys.iter().map(|y| y[o]).collect(),
        };
        let table = anova(&design, interactions).map_err(|e| match e {
            SensitivityError::Invalid(m) => {
                SensitivityError::Invalid(format!("output `{}`: {m}", names[o]))
            }
            e => e,
        })?;
        tables.push(table);
    }
    Ok(FactorialResult {
        factors: levels.iter().map(|(n, _)| n.clone()).collect(),
        runs: codes
            .iter()
            .map(|c| c.iter().enumerate().map(|(f, &k)| levels[f].1[k]).collect())
            .collect(),
        outputs: selected.iter().map(|&o| names[o].clone()).collect(),
        responses: ys
            .iter()
            .map(|y| selected.iter().map(|&o| y[o]).collect())
            .collect(),
        tables,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::{EvalError, Parameter, Scale};

    /// y = 2a + 3b + c·(a·b) with c = 0 or 1 (an interaction on demand),
    /// and a third parameter that is no factor.
    struct Additive {
        params: Vec<Parameter>,
        outputs: Vec<String>,
    }

    impl Additive {
        fn new() -> Additive {
            let p = |n: &str| Parameter::new(n, 0.0, 10.0, Scale::Linear).expect("bounds");
            Additive {
                params: vec![p("a"), p("b"), p("z")],
                outputs: vec!["sum".into(), "product".into()],
            }
        }
    }

    impl Model for Additive {
        fn parameters(&self) -> &[Parameter] {
            &self.params
        }
        fn outputs(&self) -> &[String] {
            &self.outputs
        }
        fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
            Ok(vec![2.0 * x[0] + 3.0 * x[1], x[0] * x[1]])
        }
    }

    #[test]
    fn additive_response_has_exact_main_effects_and_no_residual() {
        let m = Additive::new();
        let levels = vec![
            ("a".to_string(), vec![1.0, 2.0, 4.0]),
            ("b".to_string(), vec![0.0, 1.0]),
        ];
        let r = factorial_anova(&m, &levels, &["sum".to_string()], 1, &|_| {}).expect("runs");
        assert_eq!(r.runs.len(), 6);
        assert_eq!(r.runs[1], [1.0, 1.0]);
        let t = &r.tables[0];
        assert_eq!(t[0].source, "a");
        // SS_a = N_b Σ (2a − mean(2a))² = 2 · 4 · Σ (a − 7/3)² = 8 · 14/3.
        assert!((t[0].SS - 8.0 * 14.0 / 3.0).abs() < 1e-9, "{t:?}");
        assert_eq!(t[0].DOF, 2);
        // SS_b = N_a Σ (3b − 1.5)² = 3 · 2 · 2.25.
        assert!((t[1].SS - 13.5).abs() < 1e-9, "{t:?}");
        // Purely additive: the residual (the a:b interaction) is zero.
        assert!(t[2].SS.abs() < 1e-9 && t[2].source == "residual", "{t:?}");
    }

    #[test]
    fn interaction_lands_in_the_residual_and_errors_name_the_fix() {
        let m = Additive::new();
        let levels = vec![
            ("a".to_string(), vec![1.0, 3.0]),
            ("b".to_string(), vec![1.0, 3.0]),
        ];
        let r = factorial_anova(&m, &levels, &["product".to_string()], 1, &|_| {}).expect("runs");
        // ab on a 2×2 design: cells 1, 3, 3, 9 (mean 4), SS_total = 36,
        // SS_a = SS_b = 16, so the interaction SS is 4.
        assert!((r.tables[0][2].SS - 4.0).abs() < 1e-9, "{:?}", r.tables[0]);
        let e = factorial_anova(&m, &levels, &[], 2, &|_| {}).unwrap_err();
        assert!(e.to_string().contains("interactions: 1"), "{e}");
        let bad = vec![("q".to_string(), vec![1.0, 2.0])];
        assert!(factorial_anova(&m, &bad, &[], 1, &|_| {}).is_err());
        let outside = vec![("a".to_string(), vec![1.0, 20.0])];
        let e = factorial_anova(&m, &outside, &[], 1, &|_| {}).unwrap_err();
        assert!(e.to_string().contains("outside its bounds"), "{e}");
    }
}
