//! Integration tests of the structural-dynamics core on the reference model
//! files (known answers, model-file errors, configurations); beam sections
//! are in `beam_sections.rs`.
#![allow(non_snake_case)]

use crate::util::models::{assert_errors, err_of, no_files};
use modalflow::dynamics::{Model, PreparedModel};

fn load(name: &str) -> PreparedModel {
    let path = format!("{}/pipelines/models/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let model = Model::from_yaml(&text, name, &no_files).unwrap();
    PreparedModel::new(&model).unwrap()
}

#[test]
fn three_mass_has_three_modes_below_400_hz() {
    let p = load("three_mass.yaml");
    assert_eq!(p.n_dofs(), 3);
    let values: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let sol = p.evaluate(0, &values, 3).unwrap();
    let f = sol.frequencies_hz();
    println!("three_mass: {f:?} zeta {:?}", sol.zeta);
    assert!(f.iter().all(|&x| x > 10.0 && x < 400.0), "{f:?}");
}

#[test]
fn test_bench_modes_move_with_wpt_position() {
    let p = load("uniaxial_test_bench.yaml");
    let n = p.n_dofs();
    assert!((150..=600).contains(&n), "DOF {n}");
    assert!((60..=80).contains(&p.parameters.len()));
    assert!(p.configurations.len() >= 3);
    let values: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let mut first = Vec::new();
    for c in 0..p.configurations.len() {
        let sol = p
            .evaluate_modes(c, &values, modalflow::dynamics::ModeSelection::Below(500.0))
            .unwrap();
        let f = sol.frequencies_hz();
        println!(
            "config {c} ({}): {} modes < 500 Hz, DOF {n}: {:.1?}",
            p.configurations[c].position.label,
            f.len(),
            f
        );
        println!("  zeta+eta/2 {:.4?}", sol.damping_ratios());
        assert!(f.len() >= 20, "{} modes below 500 Hz", f.len());
        first.push(f);
    }
    // Some mode below 500 Hz shifts by > 5 % between the end positions.
    let last = first.last().unwrap();
    let moved = first[0]
        .iter()
        .zip(last)
        .any(|(a, b)| ((a - b) / a).abs() > 0.05);
    assert!(moved, "{:?} vs {:?}", first[0], last);
}

/// A guessed mode count changes where the search for the modes below a
/// frequency starts, never which modes come back: too few (the doubling
/// takes over), about right, or far too many give the same frequencies as
/// `Below` (to 1e-10; the Krylov spaces differ, so rounding does).
#[test]
fn a_guessed_mode_count_returns_the_same_modes_below_a_frequency() {
    use modalflow::dynamics::ModeSelection;
    let p = load("uniaxial_test_bench.yaml");
    let v: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let f = |s: ModeSelection| p.evaluate_modes(1, &v, s).unwrap().frequencies_hz();
    let want = f(ModeSelection::Below(400.0));
    assert!(
        want.len() > 16,
        "{} modes: the plain search needs two solves",
        want.len()
    );
    assert!(*want.last().unwrap() <= 400.0);
    for expected in [0, 5, want.len(), 3 * want.len()] {
        let got = f(ModeSelection::BelowAbout {
            hz: 400.0,
            expected,
        });
        assert_eq!(got.len(), want.len(), "expected {expected}");
        for (a, b) in got.iter().zip(&want) {
            assert!(
                (a / b - 1.0).abs() < 1e-10,
                "expected {expected}: {a} vs {b}"
            );
        }
    }
}

fn values(p: &PreparedModel) -> Vec<f64> {
    p.parameters.iter().map(|q| q.value).collect()
}

/// Φᵀ M Φ = I and ‖Kφ − λMφ‖ small on the assembled reference model.
#[test]
fn test_bench_eigen_identities() {
    let p = load("uniaxial_test_bench.yaml");
    let v = values(&p);
    let [M, K, _, _] = p.matrices(2, &v).unwrap();
    let sol = p.evaluate(2, &v, 30).unwrap();
    let n = p.n_dofs();
    let tol = 1e3 * f64::EPSILON * (n as f64).sqrt();
    let G = sol.Phi.transpose() * &M * &sol.Phi;
    for i in 0..30 {
        for j in 0..30 {
            let e = if i == j { 1.0 } else { 0.0 };
            assert!((G[(i, j)] - e).abs() < tol, "[{i},{j}] {}", G[(i, j)]);
        }
    }
    let (kn, mn) = (K.norm_l2(), M.norm_l2());
    for r in 0..30 {
        let phi = sol.Phi.col(r);
        let l = sol.eigenvalues[r];
        let res = &K * phi - &M * phi * faer::Scale(l);
        let rel = res.norm_l2() / ((kn + l * mn) * phi.norm_l2());
        assert!(
            rel <= tol,
            "mode {r}: relative residual {rel:e}, tol {tol:e}"
        );
    }
}

/// Stiffness-proportional damping (c_i = β k_i, K₀ has no body stiffness on
/// a lumped chain) is proportional, so superposition over all modes equals
/// the direct solution; light non-proportional damping stays close.
#[test]
fn superposition_matches_direct_solution() {
    let p = load("three_mass.yaml");
    let mut v = values(&p);
    let beta = 2.0e-5;
    for i in 0..4 {
        v[4 + i] = beta * v[i];
    }
    let freqs: Vec<f64> = (0..400).map(|i| i as f64).collect();
    use modalflow::frf::FrfQuantity;
    for q in [
        FrfQuantity::Receptance,
        FrfQuantity::Mobility,
        FrfQuantity::Accelerance,
    ] {
        let sol = p.evaluate(0, &v, 3).unwrap();
        let a = p.frf_superposition(&sol, q, &freqs).unwrap();
        let b = p.frf_direct(0, &v, q, &freqs).unwrap();
        assert_eq!(a.channels.len(), 3);
        for (ca, cb) in a.channels.iter().zip(&b.channels) {
            for (x, y) in ca.values.iter().zip(&cb.values) {
                assert!(
                    (x - y).norm() <= 1e-9 * y.norm().max(1e-300),
                    "{q:?} {x} vs {y}"
                );
            }
        }
    }
    // Reference (non-proportional) values: bounded error relative to the peak.
    let v = values(&p);
    let sol = p.evaluate(0, &v, 3).unwrap();
    let a = p
        .frf_superposition(&sol, FrfQuantity::Receptance, &freqs)
        .unwrap();
    let b = p
        .frf_direct(0, &v, FrfQuantity::Receptance, &freqs)
        .unwrap();
    for (ca, cb) in a.channels.iter().zip(&b.channels) {
        let peak = cb.values.iter().map(|x| x.norm()).fold(0.0, f64::max);
        let err = ca
            .values
            .iter()
            .zip(&cb.values)
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, f64::max);
        assert!(err < 0.05 * peak, "error {err} peak {peak}");
    }
}

const FREE_BODY: &str = r#"
parameters: []
bodies:
  - name: block
    rigid: {mass: 10.0, inertia: [[0.2, 0.01, 0], [0.01, 0.3, 0], [0, 0, 0.4]], cg: [0.1, 0.2, 0.3], points: {p: [0.5, 0, 0]}}
  - name: bar
    beam:
      start: [0, 0, 0]
      end: [1, 0, 0]
      elements: 8
      orientation: [0, 1, 0]
      section: {A: 1.0e-3, Iy: 1.0e-7, Iz: 2.0e-7, J: 2.0e-7, E: 2.1e11, G: 8.1e10, rho: 7850}
      loss_factor: 0.003
"#;

/// A free rigid body and a free beam: 12 rigid-body modes at ≈ 0 Hz, then
/// the beam's first elastic mode well above.
#[test]
fn free_bodies_have_six_rigid_body_modes_each() {
    let m = Model::from_yaml(FREE_BODY, "free.yaml", &no_files).unwrap();
    let p = PreparedModel::new(&m).unwrap();
    let sol = p.evaluate(0, &[], 13).unwrap();
    let f = sol.frequencies_hz();
    assert!(f[..12].iter().all(|&x| x < 1e-3), "{f:?}");
    assert!(f[12] > 10.0, "{f:?}");
    // Material damping D = η K of the bar: every elastic mode has η_r = η
    // (eq. 2.43), rigid-body modes none.
    assert!((sol.eta[12] - 0.003).abs() < 1e-9, "{:?}", sol.eta);
    assert!(sol.eta[..12].iter().all(|&e| e == 0.0), "{:?}", sol.eta);
}

fn three_mass_text() -> String {
    std::fs::read_to_string(format!(
        "{}/pipelines/models/three_mass.yaml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

#[test]
fn bad_model_files_name_file_and_field() {
    let base = three_mass_text();
    let cases = [
        (
            base.replace("stiffness: k12.k_x", "stiffness: k99.k_x"),
            "unknown parameter `k99.k_x`",
        ),
        (
            base.replace("b: {body: m1, point: c}", "b: {body: m7, point: c}"),
            "unknown body `m7`",
        ),
        (
            base.replace("mass: 1.0,", "mass: -1.0,"),
            "bodies[1].rigid.mass",
        ),
        (base.replace("value: 1.5e6", "value: .nan"), "parameters[1]"),
        (
            base.replace(
                "[[1.0e-3, 0, 0], [0, 1.0e-3, 0], [0, 0, 1.0e-3]], cg: [0.1",
                "[[1.0e-3, 0, 0], [0, -1.0e-3, 0], [0, 0, 1.0e-3]], cg: [0.1",
            ),
            "bodies[1].rigid.inertia",
        ),
        (
            base.replace(
                "connections: [{dir: x, stiffness: k1.k_x",
                "template: guide_rail, parameters: k1, connections: [{dir: x, stiffness: k1.k_x",
            ),
            "unknown variant `guide_rail`",
        ),
        (
            base.replace("  - name: m1\n", "  - name: m1\n    colour: red\n"),
            "unknown field `colour`",
        ),
        (
            base.replace(
                "connections: [{dir: x, stiffness: k1.k_x, damper: k1.c_x}]",
                "template: ball_screw_nut, parameters: k1",
            ),
            "joints[0].lead",
        ),
        (
            base.replace("upper: 6.0e6", "upper: 1.0e6"),
            "parameters[1]",
        ),
    ];
    assert_errors(&cases);
    // serde errors keep line and column.
    let e = err_of(&base.replace("  - name: m1\n", "  - name: m1\n    colour: red\n"));
    assert!(e.contains("line "), "{e}");
}

const SUPER: &str = r#"
parameters:
  - {name: k, value: 1.0e6, lower: 1.0e5, upper: 1.0e7, scale: log, kind: stiffness}
bodies:
  - name: se
    superelement:
      mass: se/m.mtx
      stiffness: se/k.mtx
      nodes:
        - {id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}
        - {id: 2, dofs: [3, 4, 5], position: [1, 0, 0]}
      points: {a: {node: 1}, b: {node: 2}}
joints:
  - {name: s1, a: {body: se, point: a}, connections: [{dir: x, stiffness: k}, {dir: y, stiffness: k}, {dir: z, stiffness: k}]}
  - {name: s2, a: {body: se, point: b}, connections: [{dir: x, stiffness: k}, {dir: y, stiffness: k}, {dir: z, stiffness: k}]}
sensors:
  - {name: b, body: se, point: b, node: 2, direction: 1}
"#;

fn mm(diag: f64, off: f64) -> Vec<u8> {
    // Two 3-DOF nodes coupled node-to-node in each direction.
    let mut s = String::from("%%MatrixMarket matrix coordinate real symmetric\n6 6 9\n");
    for i in 1..=6 {
        s += &format!("{i} {i} {diag}\n");
    }
    for i in 1..=3 {
        s += &format!("{} {i} {off}\n", i + 3);
    }
    s.into_bytes()
}

/// A super-element read through the resolver: two 1 kg nodes joined by a
/// 2e6 N/m spring, each grounded by k = 1e6: ω² = k/m and (k + 2·2e6)/m.
#[test]
fn superelement_known_answer_and_missing_file() {
    let resolver = |p: &str| -> std::io::Result<Vec<u8>> {
        match p {
            "se/m.mtx" => Ok(mm(1.0, 0.0)),
            "se/k.mtx" => Ok(mm(2.0e6, -2.0e6)),
            _ => no_files(p),
        }
    };
    let m = Model::from_yaml(SUPER, "se.yaml", &resolver).unwrap();
    let p = PreparedModel::new(&m).unwrap();
    let sol = p.evaluate(0, &[1.0e6], 6).unwrap();
    for (r, l) in sol.eigenvalues.iter().enumerate() {
        let exact = if r < 3 { 1.0e6 } else { 5.0e6 };
        assert!((l - exact).abs() < 1e-6 * exact, "{r}: {l}");
    }
    let e = Model::from_yaml(SUPER, "se.yaml", &no_files)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("se.yaml")
            && e.contains("se/m.mtx")
            && e.contains("bodies[0].superelement.mass"),
        "{e}"
    );
    // A singular (semi-definite) super-element mass matrix, M = [1 1; 1 1]
    // per direction: K + σM is definite, so the finite modes are solved,
    // λ = 1/(uᵀK⁻¹u) = 5e5 for u = (1, 1) and K = [3e6 −2e6; −2e6 3e6]
    // (with the 1e6 joint springs); the null direction (1, −1) has no finite
    // frequency and asking for it is an error that says so (issue 32).
    let singular = |p: &str| -> std::io::Result<Vec<u8>> {
        match p {
            "se/m.mtx" => Ok(mm(1.0, 1.0)),
            "se/k.mtx" => Ok(mm(2.0e6, -2.0e6)),
            _ => no_files(p),
        }
    };
    let m = Model::from_yaml(SUPER, "se.yaml", &singular).unwrap();
    let p = PreparedModel::new(&m).unwrap();
    let sol = p.evaluate(0, &m.true_values(), 3).unwrap();
    for l in &sol.eigenvalues {
        assert!((l / 5.0e5 - 1.0).abs() < 1e-12, "{:?}", sol.eigenvalues);
    }
    let e = p.evaluate(0, &m.true_values(), 4).unwrap_err().to_string();
    assert!(e.contains("rank 3 of 6"), "{e}");
}

/// Parallel batch evaluation equals sequential evaluation bit for bit.
#[test]
fn batch_evaluation_is_deterministic() {
    use rayon::prelude::*;
    let p = load("uniaxial_test_bench.yaml");
    let v0 = values(&p);
    let batch: Vec<Vec<f64>> = (0..8)
        .map(|i| v0.iter().map(|x| x * (1.0 + 0.05 * i as f64)).collect())
        .collect();
    let seq: Vec<Vec<f64>> = batch
        .iter()
        .map(|v| p.evaluate(1, v, 20).unwrap().eigenvalues)
        .collect();
    let par: Vec<Vec<f64>> = batch
        .par_iter()
        .map(|v| p.evaluate(1, v, 20).unwrap().eigenvalues)
        .collect();
    assert_eq!(seq, par);
    let e = p.evaluate(1, &v0[1..], 20).unwrap_err().to_string();
    assert!(e.contains("77 values"), "{e}");
}

/// The assembled three-mass chain equals the hand-written K and M, and its
/// eigenvalues equal those of that matrix pencil (closed form of the
/// characteristic polynomial via the eigen module's chain check).
#[test]
fn three_mass_assembly_known_answer() {
    let p = load("three_mass.yaml");
    let v = values(&p);
    let [M, K, B, D] = p.matrices(0, &v).unwrap();
    let (k1, k12, k23, k3) = (v[0], v[1], v[2], v[3]);
    let Kx = [
        [k1 + k12, -k12, 0.0],
        [-k12, k12 + k23, -k23],
        [0.0, -k23, k23 + k3],
    ];
    let mx = [1.5, 1.0, 0.8];
    for i in 0..3 {
        for j in 0..3 {
            assert!((K[(i, j)] - Kx[i][j]).abs() < 1e-9 * k1, "K[{i},{j}]");
            assert_eq!(M[(i, j)], if i == j { mx[i] } else { 0.0 });
            assert_eq!(D[(i, j)], 0.0);
        }
    }
    assert!((B[(0, 0)] - (v[4] + v[5])).abs() < 1e-12);
    // det(K − λM) = 0 at every computed eigenvalue (relative to the scale).
    let sol = p.evaluate(0, &v, 3).unwrap();
    for &l in &sol.eigenvalues {
        let a = |i: usize, j: usize| Kx[i][j] - if i == j { l * mx[i] } else { 0.0 };
        let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
            - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0));
        let scale = (k1 + k12 + k23 + k3).powi(3);
        assert!(det.abs() < 1e-10 * scale, "det {det} at λ {l}");
    }
}

/// Craig-Bampton (bed 20, column 12, screw 16 fixed-interface modes) vs the
/// unreduced beams: the lowest 20 modes of the reference model agree to < 0.1 %.
#[test]
fn craig_bampton_matches_full_test_bench() {
    let path = format!(
        "{}/pipelines/models/uniaxial_test_bench.yaml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).unwrap();
    let full_text: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("reduction:"))
        .map(|l| format!("{l}\n"))
        .collect();
    let reduced = load("uniaxial_test_bench.yaml");
    let full =
        PreparedModel::new(&Model::from_yaml(&full_text, "full.yaml", &no_files).unwrap()).unwrap();
    assert!(full.n_dofs() > reduced.n_dofs() + 200);
    let v = values(&reduced);
    for c in [0, 3] {
        let fr = reduced.evaluate(c, &v, 20).unwrap().frequencies_hz();
        let ff = full.evaluate(c, &v, 20).unwrap().frequencies_hz();
        for (r, (a, b)) in fr.iter().zip(&ff).enumerate() {
            let rel = (a - b) / b;
            // CB is a Rayleigh-Ritz projection: reduced frequencies are upper bounds.
            assert!(
                rel > -1e-9 && rel < 1e-3,
                "config {c} mode {r}: reduced {a} full {b} ({rel:e})"
            );
        }
    }
}

const SLIDER: &str = r#"
parameters:
  - {name: k_clamp, value: 1.0e12, lower: 1.0e11, upper: 1.0e13, scale: log, kind: stiffness}
  - {name: k_slide, value: 1.0e9, lower: 1.0e8, upper: 1.0e10, scale: log, kind: stiffness}
bodies:
  - name: arm
    beam:
      start: [0, 0, 0]
      end: [1, 0, 0]
      elements: 10
      orientation: [0, 1, 0]
      section: {A: 2.0e-3, Iy: 2.0e-6, Iz: 2.0e-6, J: 3.0e-6, E: 2.1e11, G: 8.1e10, rho: 7850}
      points: {root: {node: 0}, rail: {node: 0}}
  - name: carriage
    rigid: {mass: 5.0, inertia: [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]], cg: [0.1, 0, 0], points: {shoe: [0.1, 0, 0]}}
joints:
  - name: clamp
    a: {body: arm, point: root}
    connections: [{dir: x, stiffness: k_clamp}, {dir: y, stiffness: k_clamp}, {dir: z, stiffness: k_clamp},
                  {dir: rx, stiffness: k_clamp}, {dir: ry, stiffness: k_clamp}, {dir: rz, stiffness: k_clamp}]
  - name: shoe
    a: {body: carriage, point: shoe}
    b: {body: arm, point: rail}
    connections: [{dir: x, stiffness: k_slide}, {dir: y, stiffness: k_slide}, {dir: z, stiffness: k_slide},
                  {dir: rx, stiffness: k_slide}, {dir: ry, stiffness: k_slide}, {dir: rz, stiffness: k_slide}]
axes:
  - {name: x, body: carriage, direction: [1, 0, 0], positions: [0.0, 0.38, 0.52, 0.9], sliding: [shoe]}
"#;

/// A 5 kg carriage sliding out along a cantilever: the attachment snaps to
/// the nearest node (0.38 → node 5 at 0.5 m, 0.52 → node 6 at 0.6 m), and
/// the first bending frequency falls as the carriage moves to the tip.
#[test]
fn sliding_joint_follows_the_axis() {
    let m = Model::from_yaml(SLIDER, "slider.yaml", &no_files).unwrap();
    let p = PreparedModel::new(&m).unwrap();
    let labels: Vec<&str> = p
        .configurations
        .iter()
        .map(|c| c.position.label.as_str())
        .collect();
    assert_eq!(labels, ["x=0.000", "x=0.380", "x=0.520", "x=0.900"]);
    let v = m.true_values();
    let f: Vec<f64> = (0..4)
        .map(|c| p.evaluate(c, &v, 1).unwrap().frequencies_hz()[0])
        .collect();
    assert!(f.windows(2).all(|w| w[1] < w[0]), "{f:?}");
    // Positions 0.38 and 0.52 snap to different nodes.
    assert!(f[1] > 1.01 * f[2], "{f:?}");
}

/// Reference model: modal superposition over all modes (diagonal damping
/// approximation, section 2.3.1) vs the direct solution with the full
/// non-proportional B and D. The error is first order in the damping
/// coupling: small against the largest FRF of the set, and it shrinks ten
/// times when all joint damping shrinks ten times. (Against a weak cross
/// channel's own peak it can be large: close modes with different damping
/// mechanisms, e.g. 78 Hz drive and 81 Hz mount modes.)
#[test]
fn test_bench_superposition_close_to_direct() {
    use modalflow::dynamics::ParameterKind;
    use modalflow::frf::FrfQuantity;
    let p = load("uniaxial_test_bench.yaml");
    let freqs: Vec<f64> = (1..=96).map(|i| 5.0 * i as f64).collect();
    let error = |scale: f64| {
        let v: Vec<f64> = p
            .parameters
            .iter()
            .map(|q| {
                if q.kind == ParameterKind::Damping {
                    q.value * scale
                } else {
                    q.value
                }
            })
            .collect();
        let sol = p.evaluate(1, &v, p.n_dofs()).unwrap();
        let a = p
            .frf_superposition(&sol, FrfQuantity::Receptance, &freqs)
            .unwrap();
        let b = p
            .frf_direct(1, &v, FrfQuantity::Receptance, &freqs)
            .unwrap();
        let peak = b
            .channels
            .iter()
            .flat_map(|c| c.values.iter())
            .map(|x| x.norm())
            .fold(0.0, f64::max);
        let err = a
            .channels
            .iter()
            .zip(&b.channels)
            .flat_map(|(ca, cb)| {
                ca.values
                    .iter()
                    .zip(&cb.values)
                    .map(|(x, y)| (x - y).norm())
            })
            .fold(0.0, f64::max);
        err / peak
    };
    let (full, light) = (error(1.0), error(0.1));
    println!("superposition error / peak: {full:e} (joint damping x0.1: {light:e})");
    assert!(full < 0.05, "{full}");
    assert!(light < 0.3 * full, "{light} vs {full}");
}
/// `vertical:` is presentation only: the test bench (y-up) assembles bit
/// for bit the same without it.
#[test]
fn the_vertical_key_leaves_the_assembly_unchanged() {
    let path = format!(
        "{}/pipelines/models/uniaxial_test_bench.yaml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("vertical:"))
        .expect("the test bench states its vertical axis");
    assert!(line.starts_with("vertical: y"), "{line}");
    let without = text.replace(&format!("{line}\n"), "");
    let build = |t: &str| PreparedModel::new(&Model::from_yaml(t, "m.yaml", &no_files).unwrap());
    let (a, b) = (build(&text).unwrap(), build(&without).unwrap());
    let v = values(&a);
    for (x, y) in a
        .matrices(1, &v)
        .unwrap()
        .iter()
        .zip(&b.matrices(1, &v).unwrap())
    {
        assert!(x == y, "matrices differ");
    }
}
