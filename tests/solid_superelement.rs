//! The GSA and the guided update on a solid super-element (issue 32, CI
//! size): a 0.3 × 0.1 × 0.1 m steel block of 6 × 2 × 2 hexahedra
//! (`util::hex8`, 189 DOF) exported as Matrix Market, standing on four
//! elastic mounts at its bottom corners (x, y, z springs each: 12
//! stiffness parameters), sensed in x, y, z at its four top corners. Its six
//! mount modes (63–190 Hz) lie far below the block's first elastic mode
//! (~6 kHz), so the mounts are what the modes see. Truth: every mount moved
//! (up to 20 %, seed 3); the update must find it from the exact modes.

#![allow(non_snake_case)]

use crate::util::hex8::{matrix_market, Block};
use crate::util::Workspace;
use modalflow::artifacts::parameters::{read_identified, read_truth};

const MOUNTS: [(&str, [usize; 3]); 4] = [
    ("m1", [0, 0, 0]),
    ("m2", [6, 0, 0]),
    ("m3", [6, 2, 0]),
    ("m4", [0, 2, 0]),
];

/// The model file: the block's top and bottom corners as nodes (their
/// matrix rows), a mount per bottom corner, sensors at the top corners.
fn model(b: &Block) -> String {
    let mut parameters = String::from("parameters:\n");
    let mut joints = String::from("joints:\n");
    for (m, _) in MOUNTS {
        for (d, v) in [("x", 1.0e6), ("y", 1.5e6), ("z", 3.0e6)] {
            parameters.push_str(&format!(
                "  - {{name: {m}.k_{d}, value: {v:e}, lower: {:e}, upper: {:e}, scale: log, kind: stiffness}}\n",
                v / 4.0,
                v * 4.0
            ));
        }
        joints.push_str(&format!(
            "  - {{name: {m}, a: {{body: block, point: {m}}}, connections: [{{dir: x, stiffness: {m}.k_x}}, {{dir: y, stiffness: {m}.k_y}}, {{dir: z, stiffness: {m}.k_z}}]}}\n"
        ));
    }
    let (mut nodes, mut points, mut sensors) = (String::new(), String::new(), String::new());
    let top = |[i, j, _]: [usize; 3]| [i, j, 2];
    let corners = MOUNTS
        .iter()
        .map(|(m, c)| (m.to_string(), *c))
        .chain(MOUNTS.iter().map(|(m, c)| (m.replace('m', "t"), top(*c))));
    for (name, [i, j, k]) in corners {
        let n = b.node(i, j, k);
        nodes.push_str(&format!(
            "        - {{id: {}, dofs: [{}, {}, {}], position: [{}, {}, {}]}}\n",
            n + 1,
            3 * n,
            3 * n + 1,
            3 * n + 2,
            0.05 * i as f64,
            0.05 * j as f64,
            0.05 * k as f64
        ));
        points.push_str(&format!("        {name}: {{node: {}}}\n", n + 1));
    }
    for (t, (m, _)) in MOUNTS.iter().enumerate() {
        for (d, axis) in ["x", "y", "z"].iter().enumerate() {
            let t_name = m.replace('m', "t");
            sensors.push_str(&format!(
                "  - {{name: {t_name}_{axis}, body: block, point: {t_name}, node: {}, direction: {}}}\n",
                t + 1,
                d + 1
            ));
        }
    }
    format!(
        "{parameters}bodies:\n  - name: block\n    superelement:\n      mass: m.mtx\n      stiffness: k.mtx\n      loss_factor: 0.01\n      nodes:\n{nodes}      points:\n{points}{joints}sensors:\n{sensors}excitations:\n  - {{name: t3_z, body: block, point: t3, node: 3, direction: 3}}\n"
    )
}

const PIPELINE: &str = r#"name: solid
seed: 1
stages:
  nominal:
    kind: synthesize
    params: {model: block.yaml, frequency: {min: 5, max: 400, step: 1}}
  gsa:
    kind: gsa
    inputs: {reference: nominal.modes}
    params: {model: block.yaml, samples: 32, threshold: 0.05}
  truth:
    kind: synthesize
    params:
      model: block.yaml
      frequency: {min: 5, max: 400, step: 1}
      values: {perturb: {relative: 0.2, seed: 3}}
  update:
    kind: identify
    inputs: {reference: truth.modes, sensitivity: gsa.subproblems}
    params: {model: block.yaml, strategy: sensitivity_guided, budget: 8000}
"#;

#[test]
fn gsa_and_guided_update_on_a_matrix_market_solid_find_the_moved_mounts() {
    let b = Block::steel([6, 2, 2], [0.05, 0.05, 0.05]);
    let n = 3 * b.nodes();
    let (K, M) = b.assemble();
    let ws = Workspace::new();
    ws.write("k.mtx", &matrix_market(n, &K));
    ws.write("m.mtx", &matrix_market(n, &M));
    ws.write("block.yaml", &model(&b));
    ws.write("p.yaml", PIPELINE);
    let report = ws.run(&[], 0);
    assert!(report.all("ran"), "{:?}", report.statuses());

    // The screening sees every mount in some mode: z in the bounce, pitch
    // and roll, x and y in the sway and yaw modes.
    let significant = ws.read("results/solid/gsa/significant.csv");
    let kept = significant.lines().filter(|l| l.ends_with(",true")).count();
    assert_eq!(kept, 12, "{significant}");

    // The truth moved every mount; the update finds every one.
    let truth = read_truth(&ws.path().join("results/solid/truth/parameters.csv")).unwrap();
    let found = read_identified(&ws.path().join("results/solid/update/parameters.csv")).unwrap();
    let start_error = truth
        .iter()
        .map(|t| {
            (t.value
                / found
                    .iter()
                    .find(|f| f.parameter == t.parameter)
                    .unwrap()
                    .initial
                - 1.0)
                .abs()
        })
        .fold(0.0, f64::max);
    assert!(
        start_error > 0.1,
        "the truth must be away from the start: {start_error}"
    );
    for t in &truth {
        let f = found.iter().find(|f| f.parameter == t.parameter).unwrap();
        let error = (f.value / t.value - 1.0).abs();
        assert!(f.identified, "{} not identified", t.parameter);
        assert!(
            error < 1e-3,
            "{}: {} against the true {} ({error:.1e})",
            t.parameter,
            f.value,
            t.value
        );
    }
    let cost = ws.cost("results/solid/update");
    assert!(cost.verdict.ok, "{}", cost.verdict.message);
}
