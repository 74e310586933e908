//! Known answers of the eigensolver paths (issue 16): sparse and dense agree
//! on the test bench; a long cantilever with equal bending stiffness in two
//! directions (every bending frequency a double eigenvalue) matches
//! Euler–Bernoulli on both paths and finds both copies; residual
//! identities; bit-identical results across thread counts; 100 modes keep
//! every repeated eigenspace (subspace MAC).
#![allow(non_snake_case)]

use modalflow::dynamics::model_file::{SolverMethod, SolverSpec};
use modalflow::dynamics::{eigen::DEFAULT_SHIFT, ModalSolution, Model, PreparedModel};
use rayon::prelude::*;

fn bench() -> Model {
    let text = include_str!("../pipelines/models/uniaxial_test_bench.yaml");
    let files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
    Model::from_yaml(text, "uniaxial_test_bench.yaml", &files).unwrap()
}

fn with(model: &Model, method: SolverMethod, block: usize) -> PreparedModel {
    let spec = SolverSpec {
        method,
        block: Some(block),
        ..SolverSpec::default()
    };
    PreparedModel::with_solver(model, DEFAULT_SHIFT, spec).unwrap()
}

fn mac(a: &ModalSolution, b: &ModalSolution, r: usize) -> f64 {
    let n = a.Phi.nrows();
    let ab: f64 = (0..n).map(|i| a.Phi[(i, r)] * b.Phi[(i, r)]).sum();
    let aa: f64 = (0..n).map(|i| a.Phi[(i, r)].powi(2)).sum();
    let bb: f64 = (0..n).map(|i| b.Phi[(i, r)].powi(2)).sum();
    ab * ab / (aa * bb)
}

/// Backward error ‖Kφ − λMφ‖ / ((‖K‖ + |λ|‖M‖)‖φ‖) (Frobenius norms) of
/// every mode, and ‖ΦᵀMΦ − I‖_max.
fn identities(p: &PreparedModel, config: usize, values: &[f64], s: &ModalSolution) -> (f64, f64) {
    let [M, K, _, _] = p.matrices(config, values).unwrap();
    let (kn, mn) = (K.norm_l2(), M.norm_l2());
    let mut worst = 0.0f64;
    for (r, &l) in s.eigenvalues.iter().enumerate() {
        let phi = s.Phi.col(r);
        let res = (&K * phi - &M * phi * faer::Scale(l)).norm_l2();
        worst = worst.max(res / ((kn + l.abs() * mn) * phi.norm_l2()));
    }
    let G = s.Phi.transpose() * &M * &s.Phi;
    let ortho = (0..G.nrows())
        .flat_map(|i| (0..G.ncols()).map(move |j| (i, j)))
        .map(|(i, j)| (G[(i, j)] - if i == j { 1.0 } else { 0.0 }).abs())
        .fold(0.0, f64::max);
    (worst, ortho)
}

#[test]
fn sparse_and_dense_paths_agree_on_the_test_bench() {
    let m = bench();
    let (dense, sparse) = (
        with(&m, SolverMethod::Dense, 4),
        with(&m, SolverMethod::Sparse, 4),
    );
    assert_eq!(dense.solver_method(), SolverMethod::Dense);
    assert_eq!(sparse.solver_method(), SolverMethod::Sparse);
    let v = m.true_values();
    let n = dense.n_dofs();
    for c in 0..4 {
        let (a, b) = (
            dense.evaluate(c, &v, 30).unwrap(),
            sparse.evaluate(c, &v, 30).unwrap(),
        );
        for r in 0..30 {
            let (fa, fb) = (
                a.undamped_frequencies_hz()[r],
                b.undamped_frequencies_hz()[r],
            );
            assert!(
                (fa / fb - 1.0).abs() < 1e-9,
                "position {c} mode {r}: {fa} vs {fb}"
            );
            assert!(
                mac(&a, &b, r) > 0.999999,
                "position {c} mode {r}: MAC {}",
                mac(&a, &b, r)
            );
            assert!((a.zeta[r] - b.zeta[r]).abs() <= 1e-9 * a.zeta[r].abs().max(1e-12));
        }
        for s in [&a, &b] {
            let (res, ortho) = identities(&dense, c, &v, s);
            let eps = f64::EPSILON * (n as f64).sqrt();
            assert!(res < 100.0 * eps, "position {c}: backward error {res:.1e}");
            assert!(ortho < 1e-10, "position {c}: ΦᵀMΦ − I = {ortho:.1e}");
        }
    }
}

/// 10 m steel cantilever, 0.1 m × 0.1 m square section (I_y = I_z), 200
/// Euler–Bernoulli elements, clamped by stiff springs (10¹² N/m, N·m/rad) at node 0:
/// ω_n = (β_n L)² √(EI/(ρ A L⁴)), each bending frequency twice.
fn cantilever(method: &str, block: usize) -> Model {
    let yaml = format!(
        r#"
parameters:
  - {{name: clamp, value: 1.0e12, lower: 1.0e11, upper: 1.0e13, scale: log, kind: stiffness}}
bodies:
  - name: bar
    beam:
      start: [0, 0, 0]
      end: [10, 0, 0]
      elements: 200
      orientation: [0, 1, 0]
      section: {{A: 0.01, Iy: 8.333333333333333e-6, Iz: 8.333333333333333e-6, J: 1.406e-5, E: 2.1e11, G: 8.1e10, rho: 7850}}
      points: {{root: {{node: 0}}, tip: {{node: 200}}}}
joints:
  - name: clamp
    a: {{body: bar, point: root}}
    connections:
      - {{dir: x, stiffness: clamp}}
      - {{dir: y, stiffness: clamp}}
      - {{dir: z, stiffness: clamp}}
      - {{dir: rx, stiffness: clamp}}
      - {{dir: ry, stiffness: clamp}}
      - {{dir: rz, stiffness: clamp}}
sensors: [{{name: tip_y, body: bar, point: tip, node: 1, direction: 2}}]
excitations: [{{name: tip_y, body: bar, point: tip, node: 1, direction: 2}}]
solver: {{method: {method}, block: {block}}}
"#
    );
    let files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
    Model::from_yaml(&yaml, "cantilever.yaml", &files).unwrap()
}

#[test]
fn long_cantilever_matches_euler_bernoulli_with_both_copies_of_each_bending_mode() {
    let c = (2.1e11 * 8.333333333333333e-6 / (7850.0 * 0.01 * 1e4f64)).sqrt();
    let beta_l = [
        1.875104068711961,
        4.694091132974175,
        7.854757438237613,
        10.995540734875467,
        14.137_168_391_046_47,
    ];
    let mut previous: Option<Vec<f64>> = None;
    for (method, block) in [("sparse", 4), ("dense", 4), ("sparse", 2)] {
        let m = cantilever(method, block);
        let p = PreparedModel::new(&m).unwrap();
        let v = m.true_values();
        let s = p.evaluate(0, &v, 10).unwrap();
        let w: Vec<f64> = s.eigenvalues.iter().map(|l| l.sqrt()).collect();
        for (k, bl) in beta_l.iter().enumerate() {
            let exact = bl * bl * c;
            let (a, b) = (w[2 * k], w[2 * k + 1]);
            assert!(
                (a / exact - 1.0).abs() < 2e-5,
                "{method}: mode pair {k}: {a} vs {exact}"
            );
            // A double eigenvalue: both copies, equal to rounding (ε κ(K + σM),
            // κ ~ 1e12 with the clamp springs).
            assert!((b / a - 1.0).abs() < 1e-8, "{method}: pair {k}: {a} vs {b}");
        }
        let (res, ortho) = identities(&p, 0, &v, &s);
        let eps = f64::EPSILON * (p.n_dofs() as f64).sqrt();
        assert!(res < 100.0 * eps, "{method}: backward error {res:.1e}");
        assert!(
            ortho < 1e-9,
            "{method}: ΦᵀMΦ − I = {ortho:.1e} in the double eigenspaces"
        );
        // The paths agree far inside the conditioning bound ε ‖K‖/λ₁ ≈ 1e-5
        // of the clamp springs (the test bench, conditioned like a machine
        // tool, agrees to 1e-9 above).
        if let Some(prev) = &previous {
            for (a, b) in prev.iter().zip(&s.eigenvalues) {
                assert!((a / b - 1.0).abs() < 1e-6, "{method}: {a} vs {b}");
            }
        }
        previous = Some(s.eigenvalues.clone());
    }
}

#[test]
fn sparse_results_are_bit_identical_across_thread_counts() {
    let m = bench();
    let p = with(&m, SolverMethod::Sparse, 4);
    let v = m.true_values();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                (0..8)
                    .into_par_iter()
                    .map(|i| {
                        let s = p.evaluate(i % 4, &v, 20).unwrap();
                        s.eigenvalues
                            .iter()
                            .chain(&s.zeta)
                            .chain(&s.eta)
                            .map(|x| x.to_bits())
                            .collect::<Vec<u64>>()
                    })
                    .collect::<Vec<_>>()
            })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn modes_below_a_frequency_grow_the_count_until_one_lies_above() {
    let m = bench();
    let v = m.true_values();
    for method in [SolverMethod::Dense, SolverMethod::Sparse] {
        let p = with(&m, method, 4);
        let all = p.evaluate(0, &v, 60).unwrap();
        let below = p
            .evaluate_modes(0, &v, modalflow::dynamics::ModeSelection::Below(500.0))
            .unwrap();
        let f = all.undamped_frequencies_hz();
        let count = f.iter().filter(|&&x| x <= 500.0).count();
        assert_eq!(below.eigenvalues.len(), count, "{method:?}");
        assert!(
            count > 16,
            "the test bench has more than one chunk of modes below 500 Hz"
        );
    }
}

/// Subspace MAC of the eigenspace of modes `r` of `a` and `b` (M-orthonormal
/// shapes): the smallest squared cosine of the principal angles between the
/// two spans, λ_min(CᵀC) with C = Φ_aᵀ M Φ_b over those columns — 1 when they
/// span the same space, whatever basis each solver chose inside a repeated
/// eigenvalue's eigenspace. Spaces of one or two modes.
fn subspace_mac(M: &faer::Mat<f64>, a: &ModalSolution, b: &ModalSolution, r: &[usize]) -> f64 {
    let cols =
        |s: &ModalSolution| faer::Mat::from_fn(s.Phi.nrows(), r.len(), |i, j| s.Phi[(i, r[j])]);
    let (A, B) = (cols(a), cols(b));
    let C = A.transpose() * M * &B;
    let G = C.transpose() * &C;
    match r.len() {
        1 => G[(0, 0)],
        2 => {
            let (p, q, o) = (G[(0, 0)], G[(1, 1)], G[(0, 1)]);
            0.5 * (p + q) - (0.25 * (p - q).powi(2) + o * o).sqrt()
        }
        n => panic!("an eigenspace of {n} modes"),
    }
}

/// 100 modes of the square cantilever (the Lanczos with locking above 40):
/// every eigenvalue within 1e-6 of the dense solver's (the clamp springs'
/// conditioning bound, as above: the paths differ by ~4e-8), and every eigenspace
/// (the bending pairs: both copies of each double eigenvalue; the axial and
/// torsion modes alone) the same to a subspace MAC ≥ 0.999999 (issue 32).
#[test]
fn a_hundred_modes_keep_every_repeated_eigenspace() {
    let modes = 100;
    let (dense, sparse) = (cantilever("dense", 4), cantilever("sparse", 4));
    let v = dense.true_values();
    let (pd, ps) = (
        PreparedModel::new(&dense).unwrap(),
        PreparedModel::new(&sparse).unwrap(),
    );
    let (d, s) = (
        pd.evaluate(0, &v, modes).unwrap(),
        ps.evaluate(0, &v, modes).unwrap(),
    );
    assert_eq!(s.eigenvalues.len(), modes);
    for (r, (a, b)) in d.eigenvalues.iter().zip(&s.eigenvalues).enumerate() {
        assert!((b / a - 1.0).abs() < 1e-6, "mode {r}: {a} vs {b}");
    }
    // Eigenspaces: runs of eigenvalues equal to 1e-7 (a double one's two
    // copies agree to ~1e-10 here); the last mode only when its space is
    // complete (its partner is not cut off by the count).
    let [M, ..] = pd.matrices(0, &v).unwrap();
    let l = &d.eigenvalues;
    let mut r = 0;
    let mut pairs = 0;
    while r < modes {
        let mut space = vec![r];
        while space.len() < 2 && r + space.len() < modes && (l[r + space.len()] / l[r] - 1.0) < 1e-7
        {
            space.push(r + space.len());
        }
        r += space.len();
        if r == modes && space.len() == 1 && modes < l.len() {
            break;
        }
        pairs += usize::from(space.len() == 2);
        let m = subspace_mac(&M, &d, &s, &space);
        assert!(m >= 0.999999, "modes {space:?}: subspace MAC {m}");
    }
    // 35 bending pairs; the rest axial and torsion modes.
    assert_eq!(pairs, 35, "double eigenvalues among {modes} modes");
}
