//! Saltelli sampling for Sobol indices (Saltelli 2002, doi:10.1016/S0010-4655(02)00280-1;
//! Saltelli et al. 2010, doi:10.1016/j.cpc.2009.09.018) on an Owen-scrambled
//! Sobol sequence (Burley 2020, "Practical Hash-based Owen Scrambling",
//! JCGT 9(4); crate `sobol_burley`, seeded scrambling).
//!
//! Two independent N × d matrices A and B come from the first and the last d
//! dimensions of one 2d-dimensional scrambled Sobol sequence. For every base
//! row j the sample holds, as in SALib, the block
//!
//! ```text
//! A_j, AB_j^(1), …, AB_j^(d), [BA_j^(1), …, BA_j^(d),] B_j
//! ```
//!
//! where AB^(i) is A with column i taken from B (and BA^(i) the reverse, for
//! second-order indices): N·(d+2) points, or N·(2d+2) with second order.
//! Parameters outside the varied subset stay at their nominal value.

use super::super::SensitivityError;
use crate::simulator::Parameter;

/// Largest base sample supported by the scrambled sequence (2^16).
pub const MAX_SAMPLES: usize = 1 << 16;
/// Largest number of varied parameters (2d Sobol dimensions ≤ 256).
pub const MAX_VARIED: usize = (sobol_burley::NUM_DIMENSIONS / 2) as usize;

/// The parameters of a model and which of them are varied.
#[derive(Clone, Debug)]
pub struct Problem {
    pub parameters: Vec<Parameter>,
    /// Indices into `parameters` of the varied ones, in parameter order.
    pub varied: Vec<usize>,
}

impl Problem {
    /// Vary every parameter.
    pub fn new(parameters: Vec<Parameter>) -> Problem {
        let varied = (0..parameters.len()).collect();
        Problem { parameters, varied }
    }

    /// Vary only the named parameters (others stay nominal). Errors on an
    /// unknown or repeated name.
    pub fn subset(
        parameters: Vec<Parameter>,
        names: &[String],
    ) -> Result<Problem, SensitivityError> {
        let mut varied = Vec::with_capacity(names.len());
        for name in names {
            let Some(i) = parameters.iter().position(|p| &p.name == name) else {
                return Err(SensitivityError::UnknownParameter {
                    name: name.clone(),
                    known: parameters.iter().map(|p| p.name.clone()).collect(),
                });
            };
            if varied.contains(&i) {
                return Err(SensitivityError::Invalid(format!(
                    "parameter `{name}` is listed twice"
                )));
            }
            varied.push(i);
        }
        varied.sort_unstable();
        Ok(Problem { parameters, varied })
    }

    /// Number of varied parameters, d.
    pub fn dimension(&self) -> usize {
        self.varied.len()
    }

    /// Names of the varied parameters, in order.
    pub fn varied_names(&self) -> Vec<String> {
        self.varied
            .iter()
            .map(|&i| self.parameters[i].name.clone())
            .collect()
    }
}

/// The shape of a Saltelli sample: N base rows of d varied parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub d: usize,
    pub second_order: bool,
}

impl Layout {
    /// Points per base row: d + 2, or 2d + 2 with second order.
    pub fn step(&self) -> usize {
        if self.second_order {
            2 * self.d + 2
        } else {
            self.d + 2
        }
    }

    /// Total number of model evaluations.
    pub fn len(&self) -> usize {
        self.n * self.step()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A Saltelli sample: full parameter vectors (physical values) in model order.
#[derive(Clone, Debug)]
pub struct Samples {
    pub layout: Layout,
    pub points: Vec<Vec<f64>>,
    /// Advice that does not stop the analysis (N not a power of two).
    pub warnings: Vec<String>,
}

/// 64-bit seed folded into the 32-bit scrambling seed of `sobol_burley`.
fn scramble_seed(seed: u64) -> u32 {
    (seed ^ (seed >> 32)) as u32
}

/// Draw the Saltelli sample of `n` base rows (SALib's `sample(problem, N, calc_second_order, seed)`).
pub fn sample(
    problem: &Problem,
    n: usize,
    second_order: bool,
    seed: u64,
) -> Result<Samples, SensitivityError> {
    let d = problem.dimension();
    if d == 0 {
        return Err(SensitivityError::Invalid(
            "no parameter is varied; vary at least one".into(),
        ));
    }
    if d > MAX_VARIED {
        return Err(SensitivityError::Invalid(format!(
            "{d} varied parameters exceed the {MAX_VARIED} the Sobol sequence supports; analyze a subset"
        )));
    }
    if !(2..=MAX_SAMPLES).contains(&n) {
        return Err(SensitivityError::Invalid(format!(
            "sample size N = {n} must lie in 2..={MAX_SAMPLES}"
        )));
    }
    for p in &problem.parameters {
        p.validate()
            .map_err(|e| SensitivityError::Invalid(e.to_string()))?;
    }
    let mut warnings = Vec::new();
    if !n.is_power_of_two() {
        warnings.push(format!(
            "N = {n} is not a power of two, which loses the balance of the Sobol sequence; {} would be better",
            n.next_power_of_two()
        ));
    }
    let layout = Layout { n, d, second_order };
    let s = scramble_seed(seed);
    let nominal: Vec<f64> = problem.parameters.iter().map(|p| p.nominal).collect();
    let mut points = Vec::with_capacity(layout.len());
    let mut a = vec![0.0; d];
    let mut b = vec![0.0; d];
    for j in 0..n {
        for k in 0..d {
            a[k] = f64::from(sobol_burley::sample(j as u32, k as u32, s));
            b[k] = f64::from(sobol_burley::sample(j as u32, (d + k) as u32, s));
        }
        let point = |u: &[f64]| {
            let mut x = nominal.clone();
            for (k, &i) in problem.varied.iter().enumerate() {
                x[i] = problem.parameters[i].from_unit(u[k]);
            }
            x
        };
        points.push(point(&a));
        for k in 0..d {
            let mut ab = a.clone();
            ab[k] = b[k];
            points.push(point(&ab));
        }
        if second_order {
            for k in 0..d {
                let mut ba = b.clone();
                ba[k] = a[k];
                points.push(point(&ba));
            }
        }
        points.push(point(&b));
    }
    Ok(Samples {
        layout,
        points,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::Scale;

    fn params() -> Vec<Parameter> {
        vec![
            Parameter::new("k", 1e3, 1e6, Scale::Log).unwrap(),
            Parameter::new("c", -1.0, 1.0, Scale::Linear).unwrap(),
            Parameter::new("m", 2.0, 4.0, Scale::Linear).unwrap(),
        ]
    }

    #[test]
    fn layout_and_block_structure() {
        let p = Problem::new(params());
        let s = sample(&p, 8, false, 3).unwrap();
        assert_eq!(s.points.len(), 8 * 5);
        let s2 = sample(&p, 8, true, 3).unwrap();
        assert_eq!(s2.points.len(), 8 * 8);
        for j in 0..8 {
            let blk = &s2.points[j * 8..(j + 1) * 8];
            let (a, b) = (&blk[0], &blk[7]);
            for k in 0..3 {
                for m in 0..3 {
                    // AB^(k): column k from B, others from A; BA^(k) the reverse.
                    assert_eq!(blk[1 + k][m], if m == k { b[m] } else { a[m] });
                    assert_eq!(blk[4 + k][m], if m == k { a[m] } else { b[m] });
                }
            }
            // The first-order sample is the second-order one without the BA rows.
            assert_eq!(&s.points[j * 5..j * 5 + 4], &blk[..4]);
            assert_eq!(s.points[j * 5 + 4], blk[7]);
        }
    }

    #[test]
    fn samples_stay_in_bounds_and_are_stratified() {
        let p = Problem::new(params());
        let s = sample(&p, 256, false, 11).unwrap();
        for x in &s.points {
            for (v, q) in x.iter().zip(&p.parameters) {
                assert!(q.contains(*v), "{v} outside {q:?}");
            }
        }
        // Each column of A hits every one of the 16 equal strata of [0, 1) 16 times.
        for (k, q) in p.parameters.iter().enumerate() {
            let mut counts = [0usize; 16];
            for j in 0..256 {
                counts[(q.to_unit(s.points[j * 5][k]) * 16.0).floor() as usize] += 1;
            }
            assert_eq!(counts, [16; 16], "parameter {k}");
        }
        assert!(s.warnings.is_empty());
        assert_eq!(sample(&p, 100, false, 1).unwrap().warnings.len(), 1);
    }

    #[test]
    fn seeds_subsets_and_limits() {
        let p = Problem::new(params());
        let a = sample(&p, 16, false, 1).unwrap();
        assert_eq!(a.points, sample(&p, 16, false, 1).unwrap().points);
        assert_ne!(a.points, sample(&p, 16, false, 2).unwrap().points);
        let sub = Problem::subset(params(), &["m".into(), "k".into()]).unwrap();
        assert_eq!(sub.varied, vec![0, 2]);
        let s = sample(&sub, 16, false, 1).unwrap();
        assert_eq!(s.points.len(), 16 * 4);
        assert!(s.points.iter().all(|x| x[1] == 0.0));
        assert!(matches!(
            Problem::subset(params(), &["q".into()]),
            Err(SensitivityError::UnknownParameter { .. })
        ));
        assert!(sample(&p, 1, false, 1).is_err());
        assert!(sample(&p, MAX_SAMPLES + 1, false, 1).is_err());
        assert!(sample(&Problem::subset(params(), &[]).unwrap(), 8, false, 1).is_err());
    }
}
