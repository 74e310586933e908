//! Beam bodies whose section properties are parameters: the pinned-pinned
//! known answer and the errors of a bad section reference.
#![allow(non_snake_case)]

use crate::util::models::{assert_errors, no_files};
use modalflow::dynamics::{Model, PreparedModel};

/// A simply supported steel strip (800 × 50 × 5 mm) whose E and G are
/// parameters; pins are stiff springs to ground.
const SS_BEAM: &str = r#"
parameters:
  - {name: beam.E, value: 2.0e+11, lower: 1.0e+11, upper: 1.0e+12, scale: log, kind: stiffness}
  - {name: beam.G, value: 8.0e+10, lower: 1.0e+10, upper: 1.0e+11, scale: log, kind: stiffness}
  - {name: pin.k, value: 1.0e+12, lower: 1.0e+11, upper: 1.0e+13, scale: log, kind: stiffness}
  - {name: beam.eta, value: 0.002, lower: 0.0001, upper: 0.05, scale: log, kind: damping}
bodies:
  - name: beam
    beam:
      start: [0.0, 0.0, 0.0]
      end: [0.8, 0.0, 0.0]
      elements: 20
      orientation: [0.0, 1.0, 0.0]
      section: {A: 2.5e-04, Iy: 5.2083e-10, Iz: 5.2083e-08, J: 1.9521e-09, E: beam.E, G: beam.G, rho: 7880.0}
      loss_factor: beam.eta
      points: {l: {node: 0}, r: {node: 20}, m: {node: 10}}
joints:
  - {name: l, a: {body: beam, point: l}, connections: [{dir: x, stiffness: pin.k}, {dir: y, stiffness: pin.k}, {dir: z, stiffness: pin.k}, {dir: rx, stiffness: pin.k}]}
  - {name: r, a: {body: beam, point: r}, connections: [{dir: y, stiffness: pin.k}, {dir: z, stiffness: pin.k}, {dir: rx, stiffness: pin.k}]}
sensors:
  - {name: m, body: beam, point: m, node: 1, direction: 3}
"#;

/// Known answer: a pinned-pinned Euler–Bernoulli beam has
/// f_n = (n π / L)² √(E I / (ρ A)) / 2π, so its frequencies scale as √E:
/// E × 4 doubles them; a numeric E gives the same model as the parameter;
/// a parameter loss factor η gives modal loss factors η (D = η K).
#[test]
fn beam_modulus_parameter_scales_frequencies_as_sqrt_e() {
    let solve = |text: &str, values: &[f64]| {
        let m = Model::from_yaml(text, "ss.yaml", &no_files).unwrap();
        let p = PreparedModel::new(&m).unwrap();
        p.evaluate(0, values, 2).unwrap()
    };
    let x = [2.0e11, 8.0e10, 1.0e12, 0.002];
    let base = solve(SS_BEAM, &x);
    let f = base.frequencies_hz();
    let (l, ei, rho_a): (f64, f64, f64) = (0.8, 2.0e11 * 5.2083e-10, 7880.0 * 2.5e-4);
    for (n, fn_) in f.iter().enumerate() {
        let k = (n as f64 + 1.0) * std::f64::consts::PI / l;
        let exact = k * k * (ei / rho_a).sqrt() / (2.0 * std::f64::consts::PI);
        assert!(
            (fn_ / exact - 1.0).abs() < 2e-4,
            "mode {}: {fn_} vs {exact}",
            n + 1
        );
    }
    let stiffer = solve(SS_BEAM, &[8.0e11, 8.0e10, 1.0e12, 0.002]).frequencies_hz();
    for (a, b) in stiffer.iter().zip(&f) {
        // Exact but for the pins (springs of 1e12 N/m, not rigid): 1.3e-5.
        assert!((a / b - 2.0).abs() < 1e-4, "{a} / {b}");
    }
    let numeric = SS_BEAM.replace("E: beam.E, G: beam.G", "E: 2.0e+11, G: 8.0e+10");
    for (a, b) in solve(&numeric, &x).frequencies_hz().iter().zip(&f) {
        assert!((a / b - 1.0).abs() < 1e-10, "{a} vs {b}");
    }
    for eta in base.eta.iter() {
        assert!((eta / 0.002 - 1.0).abs() < 1e-4, "modal loss factor {eta}");
    }
}

#[test]
fn beam_section_parameters_are_checked_like_joint_references() {
    let cases = [
        (
            SS_BEAM.replace("E: beam.E,", "E: beam.E2,"),
            "bodies[0].beam.section.E",
        ),
        (
            SS_BEAM.replace("E: beam.E,", "E: beam.E2,"),
            "unknown parameter `beam.E2`",
        ),
        (
            SS_BEAM.replace("G: beam.G,", "G: beam.eta,"),
            "expected Stiffness",
        ),
        (
            SS_BEAM.replace("loss_factor: beam.eta", "loss_factor: pin.k"),
            "expected Damping",
        ),
        (
            SS_BEAM
                .replace(
                    "lower: 1.0e+11, upper: 1.0e+12",
                    "lower: 0.0, upper: 1.0e+12",
                )
                .replace(
                    "scale: log, kind: stiffness}\n  - {name: beam.G",
                    "scale: linear, kind: stiffness}\n  - {name: beam.G",
                ),
            "lower bound > 0",
        ),
        (
            SS_BEAM.replace(
                "      loss_factor: beam.eta\n",
                "      loss_factor: beam.eta\n      reduction: {modes: 4}\n",
            ),
            "cannot be Craig–Bampton reduced",
        ),
        (
            SS_BEAM.replace("E: beam.E,", "E: -2.0e+11,"),
            "must all be positive",
        ),
    ];
    assert_errors(&cases);
}
