//! Built-in test functions with analytic Sobol indices, the standard
//! known-answer cases for variance-based sensitivity analysis.
//!
//! - Ishigami & Homma (1990), doi:10.1109/ISUMA.1990.151285:
//!   f = sin x₁ + a sin² x₂ + b x₃⁴ sin x₁, xᵢ ~ U(−π, π), here a = 7, b = 0.1.
//! - Sobol' G function (Saltelli & Sobol' 1995, doi:10.1016/0951-8320(95)00099-2):
//!   g = Πᵢ (|4xᵢ − 2| + aᵢ) / (1 + aᵢ), xᵢ ~ U(0, 1); small aᵢ = important xᵢ.

#![allow(non_snake_case)]

use super::{check_dimension, EvalError, Model, Parameter, Scale};
use std::f64::consts::PI;

/// Analytic first-order and total Sobol indices of a test function.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalyticIndices {
    pub S1: Vec<f64>,
    pub ST: Vec<f64>,
}

/// The Ishigami function with a = 7, b = 0.1 on [−π, π]³.
pub struct Ishigami {
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    pub a: f64,
    pub b: f64,
}

fn param(name: String, lower: f64, upper: f64) -> Parameter {
    Parameter {
        nominal: 0.5 * (lower + upper),
        name,
        lower,
        upper,
        scale: Scale::Linear,
    }
}

impl Ishigami {
    pub fn new() -> Ishigami {
        Ishigami {
            parameters: (1..=3).map(|i| param(format!("x{i}"), -PI, PI)).collect(),
            outputs: vec!["y".into()],
            a: 7.0,
            b: 0.1,
        }
    }

    /// S1 and ST from the closed-form partial variances:
    /// V₁ = ½(1 + bπ⁴/5)², V₂ = a²/8, V₁₃ = 8b²π⁸/225, V = a²/8 + bπ⁴/5 + b²π⁸/18 + ½.
    pub fn analytic_indices(&self) -> AnalyticIndices {
        let (a, b) = (self.a, self.b);
        let pi4 = PI.powi(4);
        let V = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi4 * pi4 / 18.0 + 0.5;
        let V1 = 0.5 * (1.0 + b * pi4 / 5.0).powi(2);
        let V2 = a * a / 8.0;
        let V13 = 8.0 * b * b * pi4 * pi4 / 225.0;
        AnalyticIndices {
            S1: vec![V1 / V, V2 / V, 0.0],
            ST: vec![(V1 + V13) / V, V2 / V, V13 / V],
        }
    }
}

impl Default for Ishigami {
    fn default() -> Self {
        Ishigami::new()
    }
}

impl Model for Ishigami {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        check_dimension(self, x)?;
        let s1 = x[0].sin();
        Ok(vec![
            s1 + self.a * x[1].sin().powi(2) + self.b * x[2].powi(4) * s1,
        ])
    }
}

/// The Sobol' G function with one coefficient `a[i] >= 0` per input on [0, 1].
pub struct SobolG {
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    a: Vec<f64>,
}

impl SobolG {
    /// Errors when `a` is empty or holds a negative or non-finite value.
    pub fn new(a: Vec<f64>) -> Result<SobolG, EvalError> {
        if a.is_empty() {
            return Err(EvalError::Domain(
                "the Sobol-G function needs at least one coefficient `a`".into(),
            ));
        }
        if let Some((i, v)) = a
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(EvalError::Domain(format!(
                "Sobol-G coefficient a[{i}] = {v} must be a finite number >= 0"
            )));
        }
        Ok(SobolG {
            parameters: (1..=a.len())
                .map(|i| param(format!("x{i}"), 0.0, 1.0))
                .collect(),
            outputs: vec!["y".into()],
            a,
        })
    }

    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// Vᵢ = 1/(3(1 + aᵢ)²), V = Π(1 + Vᵢ) − 1, S1ᵢ = Vᵢ/V,
    /// STᵢ = Vᵢ Π_{j≠i}(1 + Vⱼ) / V.
    pub fn analytic_indices(&self) -> AnalyticIndices {
        let Vi: Vec<f64> = self
            .a
            .iter()
            .map(|a| 1.0 / (3.0 * (1.0 + a).powi(2)))
            .collect();
        let prod: f64 = Vi.iter().map(|v| 1.0 + v).product();
        let V = prod - 1.0;
        AnalyticIndices {
            S1: Vi.iter().map(|v| v / V).collect(),
            ST: Vi.iter().map(|v| v * prod / (1.0 + v) / V).collect(),
        }
    }
}

impl Model for SobolG {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        check_dimension(self, x)?;
        let g = x
            .iter()
            .zip(&self.a)
            .map(|(x, a)| ((4.0 * x - 2.0).abs() + a) / (1.0 + a))
            .product();
        Ok(vec![g])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ishigami_known_values() {
        let m = Ishigami::new();
        let y = m.evaluate(&[PI / 2.0, PI / 2.0, 1.0]).unwrap()[0];
        assert!((y - (1.0 + 7.0 + 0.1)).abs() < 1e-12);
        assert_eq!(m.evaluate(&[0.0, 0.0, 3.0]).unwrap()[0], 0.0);
        let idx = m.analytic_indices();
        // Published values (e.g. SALib's test suite): S1 ≈ [0.3139, 0.4424, 0], ST ≈ [0.5576, 0.4424, 0.2437].
        let expect_s1 = [0.3139, 0.4424, 0.0];
        let expect_st = [0.5576, 0.4424, 0.2437];
        for i in 0..3 {
            assert!((idx.S1[i] - expect_s1[i]).abs() < 1e-4);
            assert!((idx.ST[i] - expect_st[i]).abs() < 1e-4);
        }
        assert!(matches!(
            m.evaluate(&[0.0]),
            Err(EvalError::Dimension {
                expected: 3,
                got: 1
            })
        ));
    }

    #[test]
    fn sobol_g_known_values() {
        let m = SobolG::new(vec![0.0, 1.0, 9.0]).unwrap();
        // At x = 0.5 every factor is a/(1+a), so the first kills the product.
        assert_eq!(m.evaluate(&[0.5, 0.2, 0.2]).unwrap()[0], 0.0);
        // At x = 0 or 1 every factor is (2+a)/(1+a).
        let y = m.evaluate(&[1.0, 0.0, 1.0]).unwrap()[0];
        assert!((y - 2.0 * 1.5 * 1.1).abs() < 1e-12);
        let idx = m.analytic_indices();
        // Single input: S1 = ST = 1.
        let one = SobolG::new(vec![2.0]).unwrap().analytic_indices();
        assert!((one.S1[0] - 1.0).abs() < 1e-12 && (one.ST[0] - 1.0).abs() < 1e-12);
        assert!(idx.S1.iter().zip(&idx.ST).all(|(s, t)| s <= t));
        assert!(idx.S1[0] > idx.S1[1] && idx.S1[1] > idx.S1[2]);
        assert!(SobolG::new(vec![]).is_err());
        assert!(SobolG::new(vec![-1.0]).is_err());
    }
}
