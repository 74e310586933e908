//! The subproblems of the sensitivity-guided strategy (PUB3, seed section
//! 5.2.3): a GSA screening (PUB2) lists per model output its significant
//! parameters; here they become identification subproblems, one per
//! mode-shape reference.
//!
//! - Outputs `p{i}.mode{r}.frequency` and `p{i}.mode{r}.mac` of the same
//!   reference mode form ONE subproblem over the union of their significant
//!   stiffness parameters, with the mode's own criterion
//!   [`ModalObjective::mode_cost`] (1 − MAC and the smoothed NFD of that
//!   mode). PUB3 uses the mode-shape (MAC) outputs; the frequency is added
//!   because MAC alone cannot see a common scale of the stiffnesses and a
//!   single scalar criterion over many parameters is underdetermined — the
//!   mode's shape at n sensors and its frequency give up to n equations.
//! - Only the screening's significant stiffness parameters (its combined
//!   index above the threshold, PUB2) are identified when the screening
//!   lists them: PUB2 shows the others can take any value in their bounds,
//!   and a parameter that matters for one output alone is barely
//!   determined by the data and only drifts in the joint refinement.
//! - `p{i}.mode{r}.damping` outputs name the damping parameters that the
//!   damping fit identifies ([`super::damping`]); damping ratios are cheap
//!   to fit, so every damping parameter significant for one of them is.
//! - Output names are modes of the nominal model (the screening's); each
//!   lands on the reference mode paired with it ([`super::correspondence`]).
//!   Outputs of modes with no partner, of excluded modes or of unselected
//!   positions are skipped, with the reason recorded.
//!
//! [`solve`] runs SLSQP on one subproblem from several starts with the
//! parameters outside it at seeded random values within their bounds (PUB3)
//! and reports each parameter's spread over the repeats.

use super::correspondence::{Correspondence, NamedMode};
use super::{IdentifyError, ModalObjective};
use crate::dynamics::{Parameter, ParameterKind};
use crate::optimize::slsqp::{self, SlsqpParams};
use crate::optimize::Problem;
use crate::parameter::Scale;
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

/// A mode-shape subproblem: reference mode `mode` (index into the
/// reference's modes) of position slot `slot`, over the stiffness
/// `parameters`.
#[derive(Clone, Debug)]
pub struct ModeSubproblem {
    /// `p{position}.mode{r}`.
    pub name: String,
    /// The GSA outputs merged into it.
    pub outputs: Vec<String>,
    pub slot: usize,
    pub mode: usize,
    /// Parameter indices, ascending.
    pub parameters: Vec<usize>,
}

/// The subproblems derived from a screening.
#[derive(Clone, Debug, Default)]
pub struct Decomposition {
    pub subproblems: Vec<ModeSubproblem>,
    /// Damping parameters named by damping outputs, ascending.
    pub damping: Vec<usize>,
    /// (output, why it is not used).
    pub skipped: Vec<(String, String)>,
}

impl Decomposition {
    /// The stiffness parameters of all subproblems, ascending.
    pub fn stiffness(&self) -> Vec<usize> {
        let mut all: Vec<usize> = self
            .subproblems
            .iter()
            .flat_map(|s| s.parameters.iter().copied())
            .collect();
        all.sort_unstable();
        all.dedup();
        all
    }
}

enum Parsed {
    Output {
        slot: usize,
        mode: usize,
        quantity: &'static str,
    },
    Skip(String),
}

/// Parse `p{index}.mode{r}.{frequency|damping|mac}` and find its reference
/// mode through the correspondence of nominal and reference modes.
fn parse_output(
    o: &ModalObjective,
    c: &Correspondence,
    named: &[NamedMode],
    name: &str,
) -> Result<Parsed, IdentifyError> {
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
    let number: usize = m
        .strip_prefix("mode")
        .and_then(|s| s.parse().ok())
        .filter(|&n| n >= 1)
        .ok_or_else(bad)?;
    let quantity = match q {
        "frequency" => "frequency",
        "damping" => "damping",
        "mac" => "mac",
        _ => return Err(bad()),
    };
    let (slot, mode) = match c.reference_mode(index, number, named) {
        Ok(found) => found,
        Err(why) => return Ok(Parsed::Skip(why)),
    };
    if let Some(why) = o.exclusion(slot, mode) {
        return Ok(Parsed::Skip(format!(
            "its reference mode {} is left out ({why})",
            mode + 1
        )));
    }
    Ok(Parsed::Output {
        slot,
        mode,
        quantity,
    })
}

/// Build the mode-shape subproblems and the damping set from `specs`, their
/// modes found through `c` (`named`: the screening's mode frequencies);
/// `significant` (parameter names) restricts the stiffness parameters.
pub fn decompose(
    o: &ModalObjective,
    c: &Correspondence,
    named: &[NamedMode],
    specs: &[SubproblemSpec],
    significant: Option<&[String]>,
) -> Result<Decomposition, IdentifyError> {
    let params = o.parameters();
    check_significant(params, significant)?;
    let mut d = Decomposition::default();
    for s in specs {
        let (slot, mode, quantity) = match parse_output(o, c, named, &s.output)? {
            Parsed::Output {
                slot,
                mode,
                quantity,
            } => (slot, mode, quantity),
            Parsed::Skip(why) => {
                d.skipped.push((s.output.clone(), why));
                continue;
            }
        };
        let indices = spec_parameters(params, s)?;
        if quantity == "damping" {
            d.damping.extend(
                indices
                    .iter()
                    .filter(|(_, k)| *k == ParameterKind::Damping)
                    .map(|(i, _)| *i),
            );
            continue;
        }
        let stiffness: Vec<usize> = indices
            .iter()
            .filter(|(i, k)| {
                *k == ParameterKind::Stiffness
                    && significant.is_none_or(|sig| sig.contains(&params[*i].name))
            })
            .map(|(i, _)| *i)
            .collect();
        if stiffness.is_empty() {
            d.skipped.push((
                s.output.clone(),
                "no significant stiffness parameter".into(),
            ));
            continue;
        }
        d.add_mode_output(&s.output, slot, mode, stiffness);
    }
    d.damping.sort_unstable();
    d.damping.dedup();
    Ok(d)
}

/// An error when `significant` names a parameter the model does not have.
fn check_significant(
    params: &[Parameter],
    significant: Option<&[String]>,
) -> Result<(), IdentifyError> {
    if let Some(name) = significant
        .into_iter()
        .flatten()
        .find(|n| !params.iter().any(|p| p.name == **n))
    {
        return Err(IdentifyError::Invalid(format!(
            "the screening lists `{name}` as significant, which the model does not have; run the gsa stage on this model file"
        )));
    }
    Ok(())
}

/// The parameters spec `s` names (index and kind, in its order); an error
/// when it names one the model does not have.
fn spec_parameters(
    params: &[Parameter],
    s: &SubproblemSpec,
) -> Result<Vec<(usize, ParameterKind)>, IdentifyError> {
    let mut unknown = None;
    let indices: Vec<(usize, ParameterKind)> = s
        .parameters
        .iter()
        .filter_map(|name| match params.iter().position(|p| p.name == *name) {
            Some(i) => Some((i, params[i].kind)),
            None => {
                unknown = Some(name.clone());
                None
            }
        })
        .collect();
    if let Some(name) = unknown {
        return Err(IdentifyError::Invalid(format!(
            "subproblem `{}` names parameter `{name}`, which the model does not have; run the gsa stage on this model file",
            s.output
        )));
    }
    Ok(indices)
}

impl Decomposition {
    /// Add GSA output `output` of reference mode `mode` in slot `slot`, with
    /// its significant `stiffness` parameters: merged into the subproblem of
    /// the same mode when there is one, else a new subproblem.
    fn add_mode_output(&mut self, output: &str, slot: usize, mode: usize, stiffness: Vec<usize>) {
        // `p{i}.mode{r}`: the output name without its quantity (parsed above).
        let name = output
            .rsplit_once('.')
            .map_or(output.to_string(), |(mode, _)| mode.to_string());
        match self.subproblems.iter_mut().find(|m| m.name == name) {
            Some(m) => {
                m.outputs.push(output.to_string());
                m.parameters.extend(stiffness);
                m.parameters.sort_unstable();
                m.parameters.dedup();
            }
            None => {
                let mut parameters = stiffness;
                parameters.sort_unstable();
                parameters.dedup();
                self.subproblems.push(ModeSubproblem {
                    name,
                    outputs: vec![output.to_string()],
                    slot,
                    mode,
                    parameters,
                });
            }
        }
    }
}

/// What one subproblem found over its repeats.
#[derive(Clone, Debug, Serialize)]
pub struct SubproblemRun {
    /// `p{position}.mode{r}` and the GSA outputs merged into it.
    pub name: String,
    pub outputs: Vec<String>,
    /// The stiffness parameters optimized.
    pub parameters: Vec<String>,
    /// Per repeat: the values found (in `parameters` order) and the criterion.
    pub values: Vec<Vec<f64>>,
    pub objectives: Vec<f64>,
    /// Per parameter: mean in its scale (geometric for log parameters) and
    /// spread (std of ln value for log parameters, coefficient of variation
    /// for linear ones; equal to first order).
    pub mean: Vec<f64>,
    pub spread: Vec<f64>,
    pub evaluations: usize,
}

/// Mean in the parameter's scale and the spread (see [`SubproblemRun`]).
pub fn spread(values: &[f64], scale: Scale) -> (f64, f64) {
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

/// How the repeats of a subproblem place the parameters outside it and its
/// own start point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Starts {
    /// PUB3: every repeat draws the other parameters uniformly in the unit
    /// box (log-uniform for log parameters); repeat 0 starts the subproblem's
    /// own parameters at the start values, later repeats at random points.
    #[default]
    Random,
    /// Other parameters at the start values in every repeat; own start
    /// points as for `random`.
    Fixed,
}

/// Per-subproblem settings of [`solve`].
pub struct SolveSettings<'a> {
    pub slsqp: &'a SlsqpParams,
    pub repeats: usize,
    /// Evaluations per SLSQP run.
    pub budget: usize,
    /// Smoothing δ of NFD in the criterion.
    pub delta: f64,
    pub starts: Starts,
    pub seed: u64,
}

/// Run SLSQP on subproblem `sub` (`number` = its position in the list, for
/// the random streams) `repeats` times from `start` (all parameter values).
pub fn solve(
    o: &ModalObjective,
    sub: &ModeSubproblem,
    number: usize,
    start: &[f64],
    settings: &SolveSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<SubproblemRun, IdentifyError> {
    let params = o.parameters();
    let full = o.bounds()?;
    let idx = &sub.parameters;
    let bounds = full
        .select(idx)
        .map_err(|e| IdentifyError::Invalid(e.to_string()))?;
    let mut run = SubproblemRun {
        name: sub.name.clone(),
        outputs: sub.outputs.clone(),
        parameters: idx.iter().map(|&i| params[i].name.clone()).collect(),
        values: Vec::new(),
        objectives: Vec::new(),
        mean: Vec::new(),
        spread: Vec::new(),
        evaluations: 0,
    };
    for k in 0..settings.repeats {
        // One stream per (subproblem, repeat): reproducible and independent
        // of how many subproblems come before.
        let mut rng = ChaCha8Rng::seed_from_u64(
            settings.seed ^ ((number as u64) << 32 | k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let u: Vec<f64> = (0..params.len()).map(|_| rng.random::<f64>()).collect();
        let others = match settings.starts {
            Starts::Random => full.to_physical(&u),
            Starts::Fixed => start.to_vec(),
        };
        let u0: Vec<f64> = (0..idx.len()).map(|_| rng.random::<f64>()).collect();
        let x0 = if k == 0 {
            idx.iter().map(|&i| start[i]).collect()
        } else {
            bounds.to_physical(&u0)
        };
        let point = |values: &[f64]| {
            let mut x = others.clone();
            for (j, &i) in idx.iter().enumerate() {
                x[i] = values[j];
            }
            x
        };
        let batch = |points: &[Vec<f64>]| -> Vec<f64> {
            let v: Vec<f64> = points
                .par_iter()
                .map(|p| o.mode_cost(sub.slot, sub.mode, &point(p), settings.delta))
                .collect();
            progress(points.len() as u64);
            v
        };
        let problem = Problem::new(bounds.clone(), &batch, settings.budget);
        let r = slsqp::minimize(&problem, settings.slsqp, &x0)?;
        run.evaluations += r.evaluations;
        run.values.push(r.x_best);
        run.objectives.push(r.f_best);
    }
    for (j, &i) in idx.iter().enumerate() {
        let v: Vec<f64> = run.values.iter().map(|x| x[j]).collect();
        let (m, s) = spread(&v, params[i].scale);
        run.mean.push(m);
        run.spread.push(s);
    }
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::black_box::tests::{objective, truth};
    use crate::identify::correspondence::Observability;

    /// `decompose` with the correspondence at the file's values.
    fn split(
        o: &ModalObjective,
        specs: &[SubproblemSpec],
        significant: Option<&[String]>,
    ) -> Result<Decomposition, IdentifyError> {
        let c = Correspondence::new(o, &o.nominal(), Observability::all()).unwrap();
        decompose(o, &c, &[], specs, significant)
    }

    fn spec(output: &str, parameters: &[&str]) -> SubproblemSpec {
        SubproblemSpec {
            output: output.into(),
            parameters: parameters.iter().map(|s| s.to_string()).collect(),
        }
    }

    #[test]
    fn spread_is_the_cv_in_the_parameter_scale() {
        let (m, cv) = spread(&[1.0, 3.0], Scale::Linear);
        assert!((m - 2.0).abs() < 1e-15 && (cv - 0.5).abs() < 1e-15);
        let (m, cv) = spread(&[10.0, 1000.0], Scale::Log);
        assert!((m - 100.0).abs() < 1e-9 && (cv - 100f64.ln() / 2.0).abs() < 1e-12);
    }

    #[test]
    fn outputs_of_one_mode_merge_and_damping_outputs_name_the_dampers() {
        // Excluded after the correspondence is made, as `update` does.
        let mut o = objective();
        let c = Correspondence::new(&o, &o.nominal(), Observability::all()).unwrap();
        o.exclude(0, 2, "named in exclude_modes");
        let split = |o: &ModalObjective, specs: &[SubproblemSpec], sig: Option<&[String]>| {
            decompose(o, &c, &[], specs, sig)
        };
        let specs = [
            spec("p0.mode1.frequency", &["k1.k_x", "k12.k_x"]),
            spec("p0.mode1.mac", &["k23.k_x", "k1.k_x", "k1.c_x"]),
            spec("p0.mode2.mac", &["k3.k_x"]),
            spec("p0.mode3.mac", &["k12.k_x"]),
            spec("p5.mode1.mac", &["k12.k_x"]),
            spec("p0.mode2.damping", &["k1.k_x", "k12.c_x", "k3.c_x"]),
            spec("p0.mode1.damping", &["k12.c_x"]),
        ];
        let d = split(&o, &specs, None).unwrap();
        let names: Vec<&str> = d.subproblems.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["p0.mode1", "p0.mode2"]);
        assert_eq!(
            d.subproblems[0].outputs,
            ["p0.mode1.frequency", "p0.mode1.mac"]
        );
        // Stiffness only, union, in parameter order (k1, k12, k23).
        assert_eq!(d.subproblems[0].parameters, [0, 1, 2]);
        assert_eq!(d.subproblems[1].parameters, [3]);
        assert_eq!(d.damping, [5, 7]);
        assert_eq!(d.stiffness(), [0, 1, 2, 3]);
        // The excluded mode and the unknown position are skipped, with why.
        let skipped: Vec<&str> = d.skipped.iter().map(|(o, _)| o.as_str()).collect();
        assert_eq!(skipped, ["p0.mode3.mac", "p5.mode1.mac"]);
        assert!(d.skipped[0].1.contains("exclude_modes"), "{:?}", d.skipped);
        assert!(d.skipped[1].1.contains("position 5"), "{:?}", d.skipped);
        // The significant list restricts the stiffness parameters.
        let sig = ["k1.k_x".to_string(), "k3.k_x".to_string()];
        let d = split(&o, &specs, Some(&sig)).unwrap();
        assert_eq!(d.subproblems[0].parameters, [0]);
        assert_eq!(d.stiffness(), [0, 3]);
    }

    #[test]
    fn unknown_names_are_errors_that_say_what_to_do() {
        let o = objective();
        let e = split(&o, &[spec("p0.mode1.mac", &["k9.k_x"])], None).unwrap_err();
        assert!(e.to_string().contains("`k9.k_x`"), "{e}");
        let e = split(
            &o,
            &[spec("p0.mode1.mac", &["k1.k_x"])],
            Some(&["zz".into()]),
        )
        .unwrap_err();
        assert!(e.to_string().contains("`zz`"), "{e}");
        let e = split(&o, &[spec("p0.mode1", &["k1.k_x"])], None).unwrap_err();
        assert!(e.to_string().contains("p<position>.mode<r>"), "{e}");
    }

    #[test]
    fn a_subproblem_at_the_truth_with_the_others_fixed_stays_there() {
        // Mode 1 over k1 alone, every other parameter at the truth: the
        // mode's criterion is 0 at the truth and SLSQP finds it from the
        // file's value (1 equation, 1 unknown).
        let o = objective();
        let t = truth();
        let d = split(&o, &[spec("p0.mode1.frequency", &["k1.k_x"])], None).unwrap();
        let mut start = t.clone();
        start[0] = o.nominal()[0];
        let settings = SolveSettings {
            slsqp: &SlsqpParams::default(),
            repeats: 2,
            budget: 200,
            delta: 1e-3,
            starts: Starts::Fixed,
            seed: 4,
        };
        let run = solve(&o, &d.subproblems[0], 0, &start, &settings, &|_| {}).unwrap();
        assert_eq!(run.values.len(), 2);
        assert!(run.evaluations <= 400);
        for v in &run.values {
            assert!((v[0] / t[0] - 1.0).abs() < 1e-4, "{v:?} vs {}", t[0]);
        }
        assert!(run.spread[0] < 1e-4, "{:?}", run.spread);
        assert!((o.mode_cost(0, 0, &t, 1e-3)).abs() < 1e-12);
    }
}
