//! The `synthesize` stage through the CLI: reference data with a known
//! truth from the model files in pipelines/models/.

use crate::util;

use modalflow::io::read_frf_artifact;
use util::Workspace;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines/models");

fn workspace() -> Workspace {
    let ws = Workspace::new();
    for m in ["three_mass.yaml", "uniaxial_test_bench.yaml"] {
        std::fs::create_dir_all(ws.path().join("models")).unwrap();
        std::fs::copy(format!("{MODELS}/{m}"), ws.path().join("models").join(m)).unwrap();
    }
    ws
}

fn pipeline(stage_params: &str) -> String {
    format!(
        "name: syn\nseed: 5\nstages:\n  truth:\n    kind: synthesize\n    params: {stage_params}\n"
    )
}

fn frf(ws: &Workspace, stage: &str) -> Vec<modalflow::frf::FrfSet> {
    read_frf_artifact(
        &std::fs::read(ws.path().join(format!("results/syn/{stage}/frf.uff"))).unwrap(),
        "frf",
    )
    .unwrap()
}

#[test]
fn clean_frfs_peak_at_the_true_modes_and_the_truth_is_written() {
    let ws = workspace();
    ws.write(
        "p.yaml",
        &pipeline("{model: models/three_mass.yaml, frequency: {min: 50, max: 400, step: 0.25}}"),
    );
    let r = ws.run(&[], 0);
    assert_eq!(r.stage("truth")["counters"]["modes"], 3);
    let modes = ws.read("results/syn/truth/modes/modes.csv");
    let freqs: Vec<f64> = modes
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    assert_eq!(freqs.len(), 3);
    let sets = frf(&ws, "truth");
    assert_eq!(sets.len(), 1);
    assert_eq!(sets[0].channels.len(), 3, "3 sensors x 1 excitation");
    assert_eq!(sets[0].frequencies_hz.len(), 1401);
    // Eq. 2.45 rebuilt from the written truth (mass-normalized shapes and
    // damping ratios) reproduces the written FRFs: the artifacts agree.
    let shapes = ws.read("results/syn/truth/modes/mode_shapes.csv");
    let phi = |mode: usize, node: u32| -> f64 {
        let row = shapes
            .lines()
            .find(|l| l.starts_with(&format!("0,{mode},{node},")))
            .unwrap();
        row.split(',').nth(4).unwrap().parse().unwrap()
    };
    let zetas: Vec<f64> = modes
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
        .collect();
    for (ch, node) in [(0usize, 1u32), (2, 3)] {
        for k in [0usize, 301, 700, 1072, 1400] {
            let w = 2.0 * std::f64::consts::PI * sets[0].frequencies_hz[k];
            let h: num_complex::Complex64 = (0..3)
                .map(|r| {
                    let wr = 2.0 * std::f64::consts::PI * freqs[r];
                    let den = num_complex::Complex64::new(wr * wr - w * w, 2.0 * zetas[r] * wr * w);
                    phi(r + 1, node) * phi(r + 1, 1) / den
                })
                .sum();
            let got = sets[0].channels[ch].values[k];
            assert!(
                (got - h).norm() <= 1e-9 * h.norm(),
                "H{node}1 at line {k}: {got} vs {h}"
            );
        }
    }
    let truth = ws.read("results/syn/truth/parameters.csv");
    assert!(
        truth.starts_with("parameter,value,lower,upper,scale,kind\nk1.k_x,2000000.0,"),
        "{truth}"
    );
    let model: serde_json::Value = ws.json("results/syn/truth/model.json");
    assert!(model["yaml"].as_str().unwrap().contains("bodies:"));
    assert_eq!(model["parameters"].as_array().unwrap().len(), 8);
}

#[test]
fn noise_is_seeded_and_part_of_the_key() {
    let ws = workspace();
    let stage = |name: &str, seed: u64| {
        format!("  {name}:\n    kind: synthesize\n    params: {{model: models/three_mass.yaml, frequency: {{min: 0, max: 400, step: 1}}, noise: {{relative: 0.05}}, seed: {seed}}}\n")
    };
    ws.write(
        "p.yaml",
        &format!(
            "name: syn\nstages:\n{}{}{}",
            stage("a", 1),
            stage("b", 1),
            stage("c", 2)
        ),
    );
    let r = ws.run(&[], 0);
    assert_eq!(r.stage("a")["key"], r.stage("b")["key"]);
    assert_ne!(r.stage("a")["key"], r.stage("c")["key"]);
    let (a, c) = (frf(&ws, "a"), frf(&ws, "c"));
    assert_ne!(a[0].channels[0].values, c[0].channels[0].values);
}

#[test]
fn editing_the_model_file_reruns_the_stage() {
    let ws = workspace();
    ws.write(
        "p.yaml",
        &pipeline("{model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 1}}"),
    );
    ws.run(&[], 0);
    let text = ws
        .read("models/three_mass.yaml")
        .replace("mass: 1.5,", "mass: 1.6,");
    ws.write("models/three_mass.yaml", &text);
    let s = ws.status();
    assert_eq!(
        s.stage("truth")["reason"],
        "file models/three_mass.yaml changed"
    );
    assert_eq!(ws.run(&[], 0).status_of("truth"), "ran");
}

#[test]
fn bad_models_and_values_are_rejected_before_running() {
    let ws = workspace();
    let cases = [
        ("{model: models/missing.yaml, frequency: {min: 0, max: 1, step: 1}}", "does not exist"),
        ("{model: models/three_mass.yaml, frequency: {min: 10, max: 1, step: 1}}", "frequency grid"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, values: {k1.k_x: 1.0e9}}", "outside its bounds"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, values: {nope: 1.0}}", "no parameter `nope`"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, values: {perturb: {relative: 0.3, parameters: [k1.k_x, nope]}}}", "no parameter `nope`"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, sensors: [zz]}", "no sensor `zz`"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, noise: {relative: 0.1}, impact_test: {}}", "exclude each other"),
        ("{model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, impact_test: {sample_rate_hz: 150}}", "sample_rate_hz"),
    ];
    for (params, needle) in cases {
        ws.write("p.yaml", &pipeline(params));
        let out = ws.cmd(&["run", "p.yaml"]);
        let stderr = util::text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{params}: {stderr}");
        assert!(stderr.contains(needle), "{params}: {stderr}");
    }
    // A broken model file names the model file and the field.
    let bad = ws
        .read("models/three_mass.yaml")
        .replace("stiffness: k12.k_x", "stiffness: k99");
    ws.write("models/bad.yaml", &bad);
    ws.write(
        "p.yaml",
        &pipeline("{model: models/bad.yaml, frequency: {min: 0, max: 100, step: 1}}"),
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    let stderr = util::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.contains("models/bad.yaml") && stderr.contains("k99"),
        "{stderr}"
    );
    assert!(!ws.path().join("cache/runs").exists());
}

#[test]
fn perturbed_values_stay_in_bounds_and_differ_from_the_truth() {
    let ws = workspace();
    ws.write("p.yaml", &pipeline("{model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 1}, values: {perturb: {relative: 0.5, seed: 3}}}"));
    ws.run(&[], 0);
    let truth = ws.read("results/syn/truth/parameters.csv");
    let mut changed = 0;
    for line in truth.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (v, lo, hi): (f64, f64, f64) = (
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
        );
        assert!(lo <= v && v <= hi, "{line}");
        changed += usize::from(
            ![
                "2000000.0",
                "1500000.0",
                "1000000.0",
                "500000.0",
                "40.0",
                "30.0",
                "20.0",
                "10.0",
            ]
            .contains(&f[1]),
        );
    }
    assert_eq!(changed, 8);
    // `parameters` moves only those (same values as without the list: one
    // stream per parameter); the rest keep the file's values.
    ws.write("p.yaml", &pipeline("{model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 1}, values: {perturb: {relative: 0.5, seed: 3, parameters: [k12.k_x, k3.c_x]}}}"));
    let all = truth;
    ws.run(&[], 0);
    let only = ws.read("results/syn/truth/parameters.csv");
    for (a, o) in all.lines().zip(only.lines()).skip(1) {
        let name = a.split(',').next().unwrap();
        let moved = ["k12.k_x", "k3.c_x"].contains(&name);
        assert_eq!(a == o, moved, "{a} / {o}");
    }
}

#[test]
fn impact_test_gives_coherence_and_the_bench_moves_with_the_table() {
    let ws = workspace();
    ws.write(
        "p.yaml",
        "name: syn\nstages:\n  hammer:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 0.25}, impact_test: {averages: 3}}\n  bench:\n    kind: synthesize\n    params: {model: models/uniaxial_test_bench.yaml, frequency: {min: 0, max: 200, step: 1}, positions: ['wpt=0.000', 3]}\n",
    );
    ws.run(&[], 0);
    let hammer = frf(&ws, "hammer");
    let coh = hammer[0].channels[0].coherence.as_ref().expect("coherence");
    assert!(coh.iter().all(|&g| (0.0..=1.0 + 1e-12).contains(&g)));
    let bench = frf(&ws, "bench");
    assert_eq!(bench.len(), 2);
    assert_eq!(bench[0].position.label, "wpt=0.000");
    assert_eq!(bench[1].position.index, 3);
    let modes = ws.read("results/syn/bench/modes/modes.csv");
    let first = |pos: &str| -> f64 {
        modes
            .lines()
            .find(|l| l.starts_with(pos))
            .unwrap()
            .split(',')
            .nth(3)
            .unwrap()
            .parse()
            .unwrap()
    };
    assert_ne!(
        first("0,"),
        first("3,"),
        "mode frequencies depend on the table position"
    );
}
