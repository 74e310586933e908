//! A modalflow structural model ([`crate::dynamics`]) as a [`Model`] for GSA
//! and identification: parameter values in, per axis position (model
//! configuration) and reference mode three outputs —
//!
//! - `p{position}.mode{r}.frequency`: eigenfrequency of the paired model mode, Hz
//! - `p{position}.mode{r}.damping`: its damping ratio (ζ + η/2)
//! - `p{position}.mode{r}.mac`: MAC (eq. 2.62) with reference mode r
//!
//! (`r` 1-based in reference order). Model modes are paired with the
//! reference modes of the same position one-to-one by
//! [`crate::metrics::pair_modes`] within a relative frequency window. A
//! reference mode left unpaired (its partner moved out of the window or
//! another mode claimed it) takes the model mode nearest in frequency among
//! those left, so every output stays finite — such a sample simply has a low
//! MAC. Shapes are compared at the DOFs the reference and the model's sensors
//! share (same node and axis; an opposite sign flips the coefficient).
//!
//! With [`StructuralModel::with_frf_bands`], FRAC and CSF per position and
//! frequency band follow ([`super::frf_bands`]): `p{position}.band{b}.frac`
//! and `.csf`.

use super::frf_bands::FrfBands;
use super::{check_dimension, EvalError, Model, Parameter};
use crate::dynamics::{self, DynamicsError, ModalSolution, PreparedModel};
use crate::metrics::mac;
use crate::modal::ModalModel;
use crate::pairing::{pair_modes, Pairing};
use num_complex::Complex64;

/// Pairing settings.
#[derive(Clone, Copy, Debug)]
pub struct StructuralOptions {
    /// Relative frequency window for pairing (0.2 = ±20 %, eq. 2.64).
    pub window: f64,
    /// Model modes computed per position; at least the reference's count.
    pub modes: usize,
}

impl Default for StructuralOptions {
    fn default() -> Self {
        StructuralOptions {
            window: 0.2,
            modes: 0,
        }
    }
}

/// Reference modes of one position reduced to the shared DOFs.
struct Reference {
    config: usize,
    frequencies: Vec<f64>,
    shapes: Vec<Vec<Complex64>>,
    /// (model sensor row, sign) per shared DOF.
    rows: Vec<(usize, f64)>,
}

/// A prepared structural model with reference modes.
pub struct StructuralModel {
    prepared: PreparedModel,
    parameters: Vec<Parameter>,
    outputs: Vec<String>,
    references: Vec<Reference>,
    /// Position index of each reference.
    positions: Vec<u32>,
    modes: usize,
    window: f64,
    bands: Option<FrfBands>,
}

fn model_error(e: DynamicsError) -> EvalError {
    EvalError::Domain(e.to_string())
}

impl StructuralModel {
    /// Wrap `model` with reference modes per position (matched by position
    /// index). `reference = None` uses the model's own lowest `options.modes`
    /// modes at its true parameter values (a self-consistent study).
    pub fn new(
        model: &dynamics::Model,
        reference: Option<&[ModalModel]>,
        options: StructuralOptions,
    ) -> Result<StructuralModel, EvalError> {
        if !(options.window > 0.0 && options.window.is_finite()) {
            return Err(EvalError::Domain(format!(
                "pairing window {} must be a positive fraction such as 0.2",
                options.window
            )));
        }
        let prepared = PreparedModel::new(model).map_err(model_error)?;
        let parameters = model
            .parameters
            .iter()
            .map(|p| p.bounded().map_err(|e| EvalError::Domain(e.to_string())))
            .collect::<Result<Vec<_>, _>>()?;
        let own: Vec<ModalModel>;
        let reference = match reference {
            Some(r) => r,
            None => {
                if options.modes == 0 {
                    return Err(EvalError::Domain(
                        "without reference modes, give the number of model modes to use".into(),
                    ));
                }
                let values = model.true_values();
                own = (0..prepared.configurations.len())
                    .map(|c| {
                        let sol = prepared.evaluate(c, &values, options.modes)?;
                        prepared.modal_model(&sol)
                    })
                    .collect::<Result<_, _>>()
                    .map_err(model_error)?;
                &own
            }
        };
        let mut references = Vec::new();
        let mut positions = Vec::new();
        let mut outputs = Vec::new();
        let mut most = 0;
        for r in reference {
            let matched = prepared.match_reference(r).map_err(EvalError::Domain)?;
            let (config, rows, keep) = (matched.config, matched.rows, matched.keep);
            for m in 1..=r.modes.len() {
                for q in ["frequency", "damping", "mac"] {
                    outputs.push(format!("p{}.mode{m}.{q}", r.position.index));
                }
            }
            most = most.max(r.modes.len());
            positions.push(r.position.index);
            references.push(Reference {
                config,
                frequencies: r.modes.iter().map(|m| m.frequency_hz).collect(),
                shapes: r
                    .modes
                    .iter()
                    .map(|m| keep.iter().map(|&k| m.shape[k]).collect())
                    .collect(),
                rows,
            });
        }
        if outputs.is_empty() {
            return Err(EvalError::Domain("the reference has no modes".into()));
        }
        Ok(StructuralModel {
            prepared,
            parameters,
            outputs,
            references,
            positions,
            modes: options.modes.max(most),
            window: options.window,
            bands: None,
        })
    }

    /// Add FRAC and CSF outputs per position and frequency band.
    pub fn with_frf_bands(mut self, bands: FrfBands) -> StructuralModel {
        self.outputs.extend(bands.outputs());
        self.bands = Some(bands);
        self
    }

    /// The prepared model (for building [`FrfBands`] against it).
    pub fn prepared(&self) -> &PreparedModel {
        &self.prepared
    }

    /// Modes computed per position.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// The configuration of every reference position, in output order.
    pub fn reference_configs(&self) -> Vec<usize> {
        self.references.iter().map(|r| r.config).collect()
    }

    /// The modes of configuration `config` at `x`, solved once per call of
    /// `evaluate` however many outputs need them.
    fn solve<'a>(
        &self,
        solved: &'a mut Vec<ModalSolution>,
        config: usize,
        x: &[f64],
    ) -> Result<&'a ModalSolution, EvalError> {
        let at = match solved.iter().position(|s| s.config == config) {
            Some(i) => i,
            None => {
                let sol = self
                    .prepared
                    .evaluate(config, x, self.modes)
                    .map_err(model_error)?;
                solved.push(sol);
                solved.len() - 1
            }
        };
        Ok(&solved[at])
    }
}

impl Model for StructuralModel {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn named_modes(&self) -> Vec<(String, f64)> {
        self.references
            .iter()
            .zip(&self.positions)
            .flat_map(|(r, p)| {
                r.frequencies
                    .iter()
                    .enumerate()
                    .map(move |(k, f)| (format!("p{p}.mode{}", k + 1), *f))
            })
            .collect()
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        check_dimension(self, x)?;
        let mut out = Vec::with_capacity(self.outputs.len());
        let mut solved = Vec::new();
        for r in &self.references {
            let sol = self.solve(&mut solved, r.config, x)?;
            let f = sol.frequencies_hz();
            let zeta = sol.damping_ratios();
            let shapes: Vec<Vec<Complex64>> = (0..f.len())
                .map(|m| {
                    r.rows
                        .iter()
                        .map(|&(i, s)| Complex64::new(s * sol.sensor_shapes[(i, m)], 0.0))
                        .collect()
                })
                .collect();
            let pairs = pair_modes(
                &r.frequencies,
                &r.shapes,
                &f,
                &shapes,
                &Pairing::within(self.window),
            );
            let mut partner: Vec<Option<usize>> = vec![None; r.frequencies.len()];
            let mut used = vec![false; f.len()];
            for p in &pairs {
                partner[p.reference] = Some(p.candidate);
                used[p.candidate] = true;
            }
            for (i, fr) in r.frequencies.iter().enumerate() {
                let m = match partner[i] {
                    Some(m) => m,
                    None => {
                        let nearest = (0..f.len())
                            .filter(|&m| !used[m])
                            .min_by(|&a, &b| (f[a] - fr).abs().total_cmp(&(f[b] - fr).abs()))
                            .or_else(|| {
                                (0..f.len()).min_by(|&a, &b| {
                                    (f[a] - fr).abs().total_cmp(&(f[b] - fr).abs())
                                })
                            })
                            .ok_or_else(|| EvalError::Domain("the model has no modes".into()))?;
                        used[nearest] = true;
                        nearest
                    }
                };
                out.extend([f[m], zeta[m], mac(&r.shapes[i], &shapes[m])]);
            }
        }
        if let Some(bands) = &self.bands {
            for (slot, config) in bands.configs().enumerate() {
                let sol = self.solve(&mut solved, config, x)?;
                bands.criteria(slot, sol, &mut out);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensitivity::sobol::{run, SobolParams};

    /// Two masses, ground -k1- m1 -k2- m2, with dampers.
    const TWO_MASS: &str = include_str!("../../tests/fixtures/models/two_mass.yaml");

    fn model() -> StructuralModel {
        let read = |p: &str| std::fs::read(p);
        let m = dynamics::Model::from_yaml(TWO_MASS, "two_mass.yaml", &read).unwrap();
        StructuralModel::new(
            &m,
            None,
            StructuralOptions {
                window: 0.2,
                modes: 2,
            },
        )
        .unwrap()
    }

    #[test]
    fn outputs_at_the_true_values_reproduce_the_reference() {
        let m = model();
        assert_eq!(m.outputs().len(), 6);
        assert_eq!(m.outputs()[0], "p0.mode1.frequency");
        assert_eq!(m.outputs()[5], "p0.mode2.mac");
        let y = m.evaluate(&[1.0e6, 1.0e6, 20.0]).unwrap();
        // Equal masses and springs: ω² = k/m (3 ∓ √5)/2.
        let f =
            |s: f64| (1.0e6 * (3.0 + s * 5f64.sqrt()) / 2.0).sqrt() / (2.0 * std::f64::consts::PI);
        assert!((y[0] - f(-1.0)).abs() < 1e-6 * f(-1.0), "{y:?}");
        assert!((y[3] - f(1.0)).abs() < 1e-6 * f(1.0), "{y:?}");
        assert!((y[2] - 1.0).abs() < 1e-12 && (y[5] - 1.0).abs() < 1e-12);
        assert!(y[1] > 0.0 && y[4] > 0.0);
        // A changed k2 moves both modes; pairing still finds them.
        let y2 = m.evaluate(&[1.0e6, 1.5e6, 20.0]).unwrap();
        assert!(y2[0] > y[0] && y2[2] > 0.9);
    }

    #[test]
    fn sobol_on_the_structural_model() {
        let m = model();
        let p = SobolParams {
            n: 128,
            bootstrap: 10,
            ..SobolParams::default()
        };
        let r = run(&m, &p, &|_| {}).unwrap();
        assert_eq!(r.evaluations, 128 * 5);
        let damping = &r
            .outputs
            .iter()
            .find(|(o, _)| o == "p0.mode1.damping")
            .unwrap()
            .1;
        let freq = &r
            .outputs
            .iter()
            .find(|(o, _)| o == "p0.mode1.frequency")
            .unwrap()
            .1;
        // The damper matters for damping only; the frequencies ignore it.
        assert!(freq.ST[2].abs() < 1e-9, "{freq:?}");
        assert!(damping.ST[2] > 0.3, "{damping:?}");
        assert!(freq.ST[0] > 0.1 && freq.ST[1] > 0.1, "{freq:?}");
    }
}
