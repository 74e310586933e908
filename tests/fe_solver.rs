//! Solid FE models as engineers export them (issue 32): a free-free steel
//! block of 8-node hexahedra (`util::hex8`), read from Matrix Market text,
//! against an independent dense reference on the same matrices: the shift
//! chosen from the problem (rigid-body modes detected) gives the elastic
//! frequencies to 1e-9; a fixed 1 Hz shift is refused by the residual
//! check instead of returning 1e-5 errors; a lumped mass with massless
//! nodes solves and matches static condensation.
#![allow(non_snake_case)]

use crate::util::hex8::{
    condensed_eigenvalues, dense, lumped_mass, matrix_market, reference_eigenvalues, Block, Entries,
};
use modalflow::dynamics::{Model, PreparedModel};

fn model_text(solver: &str) -> String {
    format!(
        "parameters: []\nbodies:\n  - name: block\n    superelement:\n      mass: m.mtx\n      stiffness: k.mtx\n      nodes:\n        - {{id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}}\n      points: {{a: {{node: 1}}}}\nsensors: [{{name: s, body: block, point: a, node: 1, direction: 1}}]\nexcitations: [{{name: s, body: block, point: a, node: 1, direction: 1}}]\nsolver: {solver}\n"
    )
}

fn load(n: usize, K: &Entries, M: &Entries, solver: &str) -> Model {
    let (k, m) = (matrix_market(n, K), matrix_market(n, M));
    let files = move |p: &str| -> std::io::Result<Vec<u8>> {
        Ok(if p == "k.mtx" { k.clone() } else { m.clone() }.into_bytes())
    };
    Model::from_yaml(&model_text(solver), "block.yaml", &files).unwrap()
}

/// 4 × 4 × 12 elements of 1 cm (975 DOF): λ_max/λ_1 ≈ 50, λ_max ≈ 2e12,
/// so a 1 Hz shift gives κ(K + σM) ≈ 5e10.
fn block() -> Block {
    Block::steel([4, 4, 12], [0.01, 0.01, 0.01])
}

fn worst_relative_frequency_error(computed: &[f64], reference: &[f64], skip: usize) -> f64 {
    computed
        .iter()
        .zip(reference)
        .skip(skip)
        .map(|(l, e)| (l.sqrt() / e.sqrt() - 1.0).abs())
        .fold(0.0, f64::max)
}

#[test]
fn free_free_solid_elastic_frequencies_match_the_dense_reference_to_1e_9() {
    let b = block();
    let n = 3 * b.nodes();
    let (K, M) = b.assemble();
    let reference = reference_eigenvalues(&dense(n, &K), &dense(n, &M));
    // Default: shift chosen from the problem; and a shift set in the file
    // (Hz, below the first elastic mode at 11.6 kHz).
    for solver in [
        "{method: sparse}",
        "{method: dense}",
        "{method: sparse, block: 2}",
        "{method: sparse, shift: 5000}",
    ] {
        let p = PreparedModel::new(&load(n, &K, &M, solver)).unwrap();
        let s = p.evaluate(0, &[], 30).unwrap();
        if !solver.contains("shift") {
            let choice = p.shift_choice();
            assert_eq!(choice.rigid_body_modes, 6, "{solver}");
            assert!(
                choice.sigma > 1e9 && choice.sigma < reference[6],
                "{solver}: {choice:?}"
            );
        }
        assert_eq!(&s.eigenvalues[..6], &[0.0; 6], "{solver}: rigid-body modes");
        let err = worst_relative_frequency_error(&s.eigenvalues, &reference, 6);
        assert!(err < 1e-9, "{solver}: max |Δf/f| = {err:.1e}");
        // The repeated bending pairs (square section) come out as pairs.
        for r in [6, 10, 13] {
            let (a, c) = (s.eigenvalues[r], s.eigenvalues[r + 1]);
            assert!(
                (c / a - 1.0).abs() < 1e-11,
                "{solver}: pair at {r}: {a} {c}"
            );
        }
    }
}

#[test]
fn a_fixed_1_hz_shift_on_a_free_free_solid_is_an_error_not_a_silent_1e_5() {
    let b = block();
    let n = 3 * b.nodes();
    let (K, M) = b.assemble();
    let p = PreparedModel::new(&load(n, &K, &M, "{method: sparse, shift: 1}")).unwrap();
    let e = p.evaluate(0, &[], 30).unwrap_err().to_string();
    assert!(
        e.contains("fails the residual check") && e.contains("solver.shift"),
        "{e}"
    );
}

#[test]
fn massless_nodes_solve_and_match_static_condensation() {
    // Lumped mass; the middle cross-section's 25 nodes carry none.
    let b = Block::steel([4, 4, 8], [0.01, 0.01, 0.01]);
    let n = 3 * b.nodes();
    let (K, M) = b.assemble();
    let massless: Vec<usize> = (0..5)
        .flat_map(|j| (0..5).map(move |i| (i, j)))
        .map(|(i, j)| b.node(i, j, 4))
        .collect();
    let L = lumped_mass(&M, &massless);
    let reference = condensed_eigenvalues(&dense(n, &K), &dense(n, &L));
    for solver in ["{method: sparse}", "{method: dense}"] {
        let p = PreparedModel::new(&load(n, &K, &L, solver)).unwrap();
        let s = p.evaluate(0, &[], 20).unwrap();
        assert_eq!(&s.eigenvalues[..6], &[0.0; 6], "{solver}");
        let err = worst_relative_frequency_error(&s.eigenvalues, &reference, 6);
        assert!(err < 1e-9, "{solver}: max |Δf/f| = {err:.1e}");
        // Mass-normalized: φᵀ M φ = 1 with the semi-definite M.
        for r in 6..20 {
            let q: f64 = L
                .iter()
                .map(|(&(i, j), v)| s.Phi[(i, r)] * v * s.Phi[(j, r)])
                .sum();
            assert!((q - 1.0).abs() < 1e-10, "{solver}: mode {r}: {q}");
        }
    }
}

/// Many modes (issue 32): 120 modes of a free-free 1,575-DOF block, more
/// than one Lanczos run holds, so found in chunks with the converged pairs
/// locked (`src/dynamics/lanczos/locking.rs`); every elastic frequency
/// against the dense reference, the repeated bending pairs as pairs, and
/// the chunks neither miss nor double a mode (the sorted result matches
/// the reference index by index, and no two computed shapes coincide:
/// Φᵀ M Φ = I).
#[test]
fn a_hundred_and_twenty_modes_match_the_dense_reference_to_1e_9() {
    let b = Block::steel([4, 4, 20], [0.01, 0.01, 0.01]);
    let n = 3 * b.nodes();
    let (K, M) = b.assemble();
    let reference = reference_eigenvalues(&dense(n, &K), &dense(n, &M));
    let p = PreparedModel::new(&load(n, &K, &M, "{method: sparse}")).unwrap();
    let s = p.evaluate(0, &[], 120).unwrap();
    assert_eq!(s.eigenvalues.len(), 120);
    assert_eq!(&s.eigenvalues[..6], &[0.0; 6], "rigid-body modes");
    let err = worst_relative_frequency_error(&s.eigenvalues, &reference, 6);
    assert!(err < 1e-9, "max |Δf/f| = {err:.1e}");
    // Pairs of the reference (square section) are pairs here too.
    let mut pairs = 0;
    for r in 6..119 {
        if (reference[r + 1] / reference[r] - 1.0).abs() < 1e-9 {
            let (a, c) = (s.eigenvalues[r], s.eigenvalues[r + 1]);
            assert!((c / a - 1.0).abs() < 1e-10, "pair at {r}: {a} {c}");
            pairs += 1;
        }
    }
    assert!(pairs >= 10, "only {pairs} repeated pairs in the reference");
    let Md = dense(n, &M);
    let G = s.Phi.transpose() * &Md * &s.Phi;
    let off = (&G - faer::Mat::<f64>::identity(120, 120)).norm_max();
    assert!(off < 1e-9, "Φᵀ M Φ − I = {off:.1e}: a mode doubled or lost");
}
