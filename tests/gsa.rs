//! The `gsa` stage through the CLI: Sobol indices of the Ishigami function,
//! a user's simulator as a JSON-lines command, ANOVA of a factorial table,
//! and validation of its params.

mod adequacy;

use crate::util;

use serde_json::Value;
use util::{text, Workspace};

/// `(output, parameter) -> [S1, S1_conf, ST, ST_conf]` from indices.csv.
fn indices(csv: &str) -> Vec<(String, String, [f64; 4])> {
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("output,parameter,S1,S1_conf,ST,ST_conf"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].to_string(), f[1].to_string(), [v(2), v(3), v(4), v(5)])
        })
        .collect()
}

#[test]
fn sobol_on_ishigami_writes_indices_screening_and_heatmap() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: g\nseed: 5\nstages:\n  ishigami:\n    kind: gsa\n    params: {model: {builtin: ishigami}, samples: 1024, bootstrap: 50, threshold: 0.1}\n",
    );
    let report = ws.run(&[], 0);
    assert_eq!(
        report.stage("ishigami")["counters"]["evaluations"],
        1024 * 5
    );
    let rows = indices(&ws.read("results/g/ishigami/indices.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r.1.as_str()).collect();
    assert_eq!(names, ["x1", "x2", "x3"]);
    // Analytic: S1 = [0.3139, 0.4424, 0], ST = [0.5576, 0.4424, 0.2437].
    let (s1, st) = ([0.3139, 0.4424, 0.0], [0.5576, 0.4424, 0.2437]);
    for (i, (_, _, v)) in rows.iter().enumerate() {
        assert!((v[0] - s1[i]).abs() < 0.05, "S1 {i}: {v:?}");
        assert!((v[2] - st[i]).abs() < 0.05, "ST {i}: {v:?}");
        assert!(v[1] > 0.0 && v[3] > 0.0);
    }
    let sub: Value = ws.json("results/g/ishigami/subproblems.json");
    assert_eq!(sub["significant"], serde_json::json!(["x1", "x2", "x3"]));
    assert_eq!(sub["subproblems"][0]["output"], "y");
    assert_eq!(sub["threshold"], 0.1);
    let svg = ws.read("results/g/ishigami/sobol.svg");
    assert!(svg.starts_with("<svg") && svg.contains(">x3</text>"));
    // Ranked by total index: x1 (0.56) > x2 (0.44) > x3 (0.24).
    let ranking = ws.read("results/g/ishigami/ranking.csv");
    let order: Vec<&str> = ranking
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(order, ["x1", "x2", "x3"], "{ranking}");
    assert!(ranking.starts_with("rank,parameter,score,significant\n1,x1,"));
    // A rerun is cached and the seed is part of the key.
    assert_eq!(ws.run(&[], 0).status_of("ishigami"), "cached");
    ws.write("p.yaml", &ws.read("p.yaml").replace("seed: 5", "seed: 6"));
    assert_eq!(ws.run(&[], 0).status_of("ishigami"), "ran");
    assert_ne!(indices(&ws.read("results/g/ishigami/indices.csv")), rows);
}

#[test]
fn command_model_subset_and_weights() {
    let ws = Workspace::new();
    // y1 = a + 2 b (c fixed), y2 = b: a linear model with known indices.
    ws.write(
        "sim.sh",
        "awk -F'[:,}]' '{ printf \"{\\\"y1\\\": %.17g, \\\"y2\\\": %.17g}\\n\", $2 + 2 * $4 + $6, $4 }'\n",
    );
    ws.write(
        "p.yaml",
        r#"name: c
stages:
  sim:
    kind: gsa
    params:
      model:
        command: sh sim.sh
        parameters:
          a: {lower: 0, upper: 1}
          b: {lower: 0, upper: 1}
          c: {lower: 0, upper: 1, nominal: 0.25}
        outputs: [y1, y2]
        timeout: 60
        batch: 300
      deps: [sim.sh]
      parameters: [a, b]
      samples: 256
      bootstrap: 10
      weights: {y1: 1, y2: 0}
      threshold: 0.3
      seed: 1
"#,
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("sim")["counters"]["evaluations"], 256 * 4);
    let rows = indices(&ws.read("results/c/sim/indices.csv"));
    // Var(a) : Var(2b) = 1 : 4, so S1 = ST = [0.2, 0.8] for y1 and [0, 1] for y2.
    let expect = [
        ("y1", "a", 0.2),
        ("y1", "b", 0.8),
        ("y2", "a", 0.0),
        ("y2", "b", 1.0),
    ];
    assert_eq!(rows.len(), 4);
    for ((o, p, v), (eo, ep, e)) in rows.iter().zip(expect) {
        assert_eq!((o.as_str(), p.as_str()), (eo, ep));
        assert!(
            (v[0] - e).abs() < 0.02 && (v[2] - e).abs() < 0.02,
            "{o} {p}: {v:?}"
        );
    }
    let sub: Value = ws.json("results/c/sim/subproblems.json");
    // Only y1 counts in the combination: ST(a) = 0.2 < 0.3.
    assert_eq!(sub["significant"], serde_json::json!(["b"]));
    assert_eq!(sub["non_significant"], serde_json::json!(["a"]));
    assert_eq!(
        sub["subproblems"][1]["parameters"],
        serde_json::json!(["b"])
    );
    // Editing the simulator (a dep) reruns the stage.
    ws.write("sim.sh", &(ws.read("sim.sh") + "# edited\n"));
    assert_eq!(ws.run(&[], 0).status_of("sim"), "ran");
}

#[test]
fn an_output_constant_over_every_sample_is_a_stage_warning() {
    let ws = Workspace::new();
    // y1 = a + b varies, y2 = 3 does not: its Sobol indices are undefined
    // (0/0), set to 0, and the user is told — on the command line and in
    // the run's warnings, not only inside subproblems.json.
    ws.write(
        "sim.sh",
        "awk -F'[:,}]' '{ printf \"{\\\"y1\\\": %.17g, \\\"y2\\\": 3}\\n\", $2 + $4 }'\n",
    );
    ws.write(
        "p.yaml",
        r#"name: k
stages:
  sim:
    kind: gsa
    params:
      model:
        command: sh sim.sh
        parameters:
          a: {lower: 0, upper: 1}
          b: {lower: 0, upper: 1}
        outputs: [y1, y2]
        timeout: 60
        batch: 300
      deps: [sim.sh]
      samples: 64
      bootstrap: 10
      seed: 1
"#,
    );
    let report = ws.run(&[], 0);
    let warnings = report.stage("sim")["warnings"].to_string();
    assert!(
        warnings.contains("output `y2`: the output is constant (3)"),
        "{warnings}"
    );
    assert!(!warnings.contains("`y1`"), "{warnings}");
    let sub: Value = ws.json("results/k/sim/subproblems.json");
    assert!(sub["warnings"].to_string().contains("output `y2`"), "{sub}");
    // The warnings stay with the results: in the manifest and in `show`,
    // from the results folder and, once it is gone, from the cache.
    let manifest: Value = ws.json("results/k/sim/manifest.json");
    assert!(
        manifest["warnings"][0]
            .as_str()
            .unwrap()
            .contains("output `y2`"),
        "{manifest}"
    );
    for _ in 0..2 {
        let out = ws.cmd(&["show", "p.yaml", "sim"]);
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            text.contains("warning  output `y2`: the output is constant"),
            "{text}"
        );
        std::fs::remove_dir_all(ws.path().join("results")).unwrap_or_default();
    }
}

#[test]
fn failing_command_samples_fail_the_stage_with_the_sample_index() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        r#"name: f
stages:
  sim:
    kind: gsa
    params:
      model:
        command: "awk 'NR == 7 { print \"{\\\"error\\\": \\\"solver diverged\\\"}\"; next } { print \"[1]\" }'"
        parameters: {a: {lower: 0, upper: 1}}
        outputs: [y]
      samples: 8
"#,
    );
    let report = ws.run(&[], 1);
    let error = report.stage("sim")["error"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        error.contains("sample 6") && error.contains("solver diverged"),
        "{error}"
    );
}

#[test]
fn anova_on_a_factorial_table() {
    let ws = Workspace::new();
    ws.write(
        "data/coffee.csv",
        include_str!("../src/sensitivity/testdata/coffee_anova.csv"),
    );
    ws.write(
        "p.yaml",
        "name: a\nstages:\n  coffee:\n    kind: gsa\n    params: {method: anova, data: data/coffee.csv, response: rating, interactions: 2}\n",
    );
    ws.run(&[], 0);
    let csv = ws.read("results/a/coffee/anova.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "source,SSB,dof,MS,F,p");
    let sources: Vec<&str> = lines[1..]
        .iter()
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(
        sources,
        [
            "sugar",
            "container",
            "temperature",
            "sugar:container",
            "sugar:temperature",
            "container:temperature",
            "residual"
        ]
    );
    let container: Vec<f64> = lines[2]
        .split(',')
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    // statsmodels: SS 77.0416…, DOF 1, F 54.382…, p 3.4866e-06.
    assert!((container[0] - 77.04166666666667).abs() < 1e-9);
    assert_eq!(container[1], 1.0);
    assert!((container[3] - 54.38235294117644).abs() < 1e-9);
    assert!((container[4] - 3.486585197998739e-06).abs() < 1e-12);
    let residual: Vec<&str> = lines[7].split(',').collect();
    assert!((residual[1].parse::<f64>().unwrap() - 19.833333333333332).abs() < 1e-9);
    assert_eq!(
        (residual[2], residual[4], residual[5]),
        ("14", "", ""),
        "F and p are empty for the residual"
    );
    // Editing the data file reruns the stage.
    assert_eq!(ws.run(&[], 0).status_of("coffee"), "cached");
    ws.write(
        "data/coffee.csv",
        &ws.read("data/coffee.csv")
            .replace("yes,disposable,low,1\n", "yes,disposable,low,2\n"),
    );
    assert_eq!(ws.run(&[], 0).status_of("coffee"), "ran");
}

#[test]
fn invalid_params_are_located() {
    let ws = Workspace::new();
    ws.write(
        "p.yaml",
        "name: v\nstages:\n  bad:\n    kind: gsa\n    params:\n      model:\n        command: ./sim\n        parameters: {k: {lower: 0, upper: 10, scale: log}}\n        outputs: [f]\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(err.contains("log scale needs lower > 0"), "{err}");
    assert!(err.contains("p.yaml:8:"), "{err}");
    ws.write(
        "p.yaml",
        "name: v\nstages:\n  bad:\n    kind: gsa\n    params: {method: anova, data: t.csv, response: y, samples: 8}\n",
    );
    ws.write("t.csv", "a,y\n1,2\n2,3\n");
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(
        err.contains("param `samples` belongs to method `sobol`"),
        "{err}"
    );
    ws.write(
        "p.yaml",
        "name: v\nstages:\n  bad:\n    kind: gsa\n    params: {model: {builtin: ishigami}, outputs: [z], weights: {q: 1}}\n",
    );
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(err.contains("output `z` is unknown"), "{err}");
}

const TWO_MASS: &str = include_str!("fixtures/models/two_mass.yaml");

#[test]
fn sobol_on_a_structural_model_file() {
    let ws = Workspace::new();
    ws.write("models/two_mass.yaml", TWO_MASS);
    ws.write(
        "p.yaml",
        "name: s\nstages:\n  gsa:\n    kind: gsa\n    params: {model: models/two_mass.yaml, modes: 2, samples: 64, bootstrap: 10, outputs: [p0.mode1.frequency, p0.mode1.damping], threshold: 0.05}\n",
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("gsa")["counters"]["evaluations"], 64 * 5);
    let rows = indices(&ws.read("results/s/gsa/indices.csv"));
    assert_eq!(rows.len(), 6);
    let get = |o: &str, p: &str| rows.iter().find(|r| r.0 == o && r.1 == p).unwrap().2;
    // The damper cannot move an eigenfrequency, but sets the damping ratio.
    assert_eq!(get("p0.mode1.frequency", "c1")[2], 0.0);
    assert!(get("p0.mode1.damping", "c1")[2] > 0.3);
    let sub: Value = ws.json("results/s/gsa/subproblems.json");
    assert_eq!(
        sub["subproblems"][0]["parameters"],
        serde_json::json!(["k1", "k2"])
    );
    // Editing the model file reruns the stage: it is hashed into the key.
    ws.write(
        "models/two_mass.yaml",
        &TWO_MASS.replace("mass: 1.0, inertia", "mass: 1.1, inertia"),
    );
    assert_eq!(
        ws.status().stage("gsa")["reason"],
        "file models/two_mass.yaml changed"
    );
    assert_eq!(ws.run(&[], 0).status_of("gsa"), "ran");
    // A missing or broken model file is a validation error naming it.
    ws.write("p.yaml", "name: s\nstages:\n  gsa:\n    kind: gsa\n    params: {model: models/none.yaml, modes: 2}\n");
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(err.contains("models/none.yaml"), "{err}");
}

#[test]
fn structural_model_against_reference_modes_from_another_stage() {
    let ws = Workspace::new();
    ws.write("models/two_mass.yaml", TWO_MASS);
    // Measured-like reference: the two modes of the chain, f = √(k (3 ∓ √5)/2)/2π.
    ws.write(
        "data/modes.csv",
        "mode,frequency_hz,damping_ratio\n1,98.4,0.01\n2,257.5,0.02\n",
    );
    ws.write(
        "data/mode_shapes.csv",
        "mode,node,direction,real\n1,1,+X,1\n1,2,+X,1.618\n2,1,+X,1\n2,2,+X,-0.618\n",
    );
    ws.write(
        "p.yaml",
        r#"name: r
stages:
  measured:
    kind: command
    params: {cmd: "cp -r data ref", deps: [data], outs: [ref]}
  gsa:
    kind: gsa
    inputs: {reference: measured.ref}
    params:
      model: models/two_mass.yaml
      samples: 64
      bootstrap: 5
      outputs: [p0.mode1.mac, p0.mode2.frequency]
"#,
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("gsa")["counters"]["evaluations"], 64 * 5);
    let rows = indices(&ws.read("results/r/gsa/indices.csv"));
    let outputs: Vec<&str> = rows.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(
        outputs,
        ["p0.mode1.mac"; 3]
            .iter()
            .chain(&["p0.mode2.frequency"; 3])
            .copied()
            .collect::<Vec<_>>()
    );
    // Shapes and frequencies do not depend on the damper.
    assert!(
        rows.iter().filter(|r| r.1 == "c1").all(|r| r.2[2] == 0.0),
        "{rows:?}"
    );
    // Unknown outputs of a model file are reported when the stage runs.
    ws.write(
        "p.yaml",
        &ws.read("p.yaml")
            .replace("p0.mode2.frequency", "p0.mode9.frequency"),
    );
    let report = ws.run(&[], 1);
    let error = report.stage("gsa")["error"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        error.contains("p0.mode9.frequency") && error.contains("p0.mode2.frequency"),
        "{error}"
    );
}

#[test]
fn frf_bands_split_and_monte_carlo_validation() {
    let ws = Workspace::new();
    ws.write("models/two_mass.yaml", TWO_MASS);
    ws.write(
        "p.yaml",
        r#"name: v
seed: 4
stages:
  truth:
    kind: synthesize
    params: {model: models/two_mass.yaml, frequency: {min: 20, max: 400, step: 1}}
  gsa:
    kind: gsa
    inputs: {reference: truth.modes, reference_frf: truth.frf}
    params:
      model: models/two_mass.yaml
      samples: 64
      bootstrap: 10
      bands: {min: 40, max: 360, count: 2}
      threshold: 0.05
      weights: {p0.mode1.damping: 0, p0.mode2.damping: 0}
      validation: 300
"#,
    );
    let report = ws.run(&[], 0);
    assert_eq!(
        report.stage("gsa")["counters"]["evaluations"],
        64 * 5 + 300 + 1
    );
    let rows = indices(&ws.read("results/v/gsa/indices.csv"));
    assert!(rows.iter().any(|r| r.0 == "p0.band2.csf"), "{rows:?}");
    // The damper shapes the resonance peaks: FRAC sees it, the MAC does not.
    let st = |o: &str, p: &str| rows.iter().find(|r| r.0 == o && r.1 == p).unwrap().2[2];
    assert!(st("p0.band1.frac", "c1") > 0.01, "{rows:?}");
    assert_eq!(st("p0.mode1.mac", "c1"), 0.0);
    let significant = ws.read("results/v/gsa/significant.csv");
    assert!(
        significant.starts_with(
            "parameter,score,score_low,score_high,undecided,samples_needed,significant\nk1,"
        ),
        "{significant}"
    );
    assert_eq!(significant.lines().count(), 4);
    // Without the damping outputs the damper falls below the threshold, so the
    // validation draws it at random: MAC cannot notice, FRAC and CSF do, a little.
    let v: Value = ws.json("results/v/gsa/validation.json");
    assert_eq!(v["random"], serde_json::json!(["c1"]));
    assert_eq!(v["headline"], "criterion");
    let (min, mean) = (v["min"].as_f64().unwrap(), v["mean"].as_f64().unwrap());
    assert!(min > 0.5 && min < mean && mean < 1.0, "{v}");
    let table = ws.read("results/v/gsa/validation.csv");
    let mac = table
        .lines()
        .find(|l| l.starts_with("p0.mode1.mac,"))
        .unwrap();
    assert!(mac.starts_with("p0.mode1.mac,criterion,1,1,1,1"), "{mac}");
    assert!(ws.read("results/v/gsa/validation.svg").contains("<svg"));
}

#[test]
fn anova_of_a_factorial_design_run_on_a_model() {
    let ws = Workspace::new();
    ws.write("models/two_mass.yaml", TWO_MASS);
    ws.write(
        "p.yaml",
        r#"name: a
stages:
  wear:
    kind: gsa
    params:
      method: anova
      model: models/two_mass.yaml
      modes: 2
      levels: {k1: [6.0e5, 1.0e6, 1.6e6], k2: [6.0e5, 1.6e6], c1: [15, 30]}
      outputs: [p0.mode1.frequency, p0.mode2.damping]
      interactions: 2
"#,
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("wear")["counters"]["evaluations"], 12);
    let csv = ws.read("results/a/wear/anova.csv");
    let row = |o: &str, s: &str| -> Vec<String> {
        csv.lines()
            .find(|l| l.starts_with(&format!("{o},{s},")))
            .unwrap_or_else(|| panic!("{o} {s} in {csv}"))
            .split(',')
            .map(str::to_string)
            .collect()
    };
    assert!(csv.starts_with("output,source,SSB,dof,MS,F,p\n"), "{csv}");
    assert_eq!(row("p0.mode1.frequency", "k1")[3], "2");
    assert_eq!(row("p0.mode1.frequency", "k1:k2")[3], "2");
    assert_eq!(row("p0.mode1.frequency", "residual")[3], "2");
    // The damper cannot move an eigenfrequency: no sum of squares at all.
    assert_eq!(
        row("p0.mode1.frequency", "c1")[2].parse::<f64>().unwrap(),
        0.0
    );
    let p_k1: f64 = row("p0.mode1.frequency", "k1")[6].parse().unwrap();
    assert!(p_k1 < 0.05, "{csv}");
    assert!(row("p0.mode2.damping", "c1")[2].parse::<f64>().unwrap() > 0.0);
    let runs = ws.read("results/a/wear/runs.csv");
    assert!(
        runs.starts_with("k1,k2,c1,p0.mode1.frequency,p0.mode2.damping\n600000,600000,15,"),
        "{runs}"
    );
    assert!(ws.read("results/a/wear/anova.svg").contains("<svg"));
    // A level outside the bounds, or `levels` without a model, is named.
    ws.write("p.yaml", "name: a\nstages:\n  wear:\n    kind: gsa\n    params: {method: anova, levels: {k1: [1, 2]}}\n");
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(err.contains("`levels` needs a `model`"), "{err}");
}

#[test]
fn anova_of_modal_models_from_matrix_runs() {
    let ws = Workspace::new();
    ws.write("models/two_mass.yaml", TWO_MASS);
    ws.write(
        "p.yaml",
        r#"name: m
stages:
  healthy:
    kind: synthesize
    params: {model: models/two_mass.yaml, frequency: {min: 20, max: 400, step: 1}}
  states:
    kind: synthesize
    matrix: {k1: [1.0, 0.8, 0.6], k2: [1.0, 0.7], c: [1]}
    params:
      model: models/two_mass.yaml
      frequency: {min: 20, max: 400, step: 1}
      values: {scale: {k1: "${matrix.k1}", "k2*": "${matrix.k2}"}}
  wear:
    kind: gsa
    inputs: {modes: "states[*].modes", reference: healthy.modes}
    params: {method: anova, interactions: 1, window: 0.5}
"#,
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("wear")["counters"]["runs"], 6);
    let runs = ws.read("results/m/wear/runs.csv");
    // `c` never varies, so only k1 and k2 are factors.
    assert!(
        runs.starts_with("k1,k2,p0.mode1.frequency,p0.mode1.damping,"),
        "{runs}"
    );
    assert!(
        runs.lines().nth(1).unwrap().starts_with("1.0,1.0,98.36"),
        "{runs}"
    );
    let csv = ws.read("results/m/wear/anova.csv");
    let ss = |o: &str, s: &str| -> f64 {
        csv.lines()
            .find(|l| l.starts_with(&format!("{o},{s},")))
            .unwrap_or_else(|| panic!("{o} {s}: {csv}"))
            .split(',')
            .nth(2)
            .unwrap()
            .parse()
            .unwrap()
    };
    // Both springs move both modes; k1 (grounded) dominates mode 1.
    assert!(
        ss("p0.mode1.frequency", "k1") > ss("p0.mode1.frequency", "k2"),
        "{csv}"
    );
    assert!(ss("p0.mode2.frequency", "k2") > 0.0);
    // A `modes` input on a Sobol stage, or a modal ANOVA without it, is refused.
    ws.write(
        "p.yaml",
        "name: m\nstages:\n  wear:\n    kind: gsa\n    params: {method: anova}\n",
    );
    let err = text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(
        err.contains("bind the `modes` and `reference` inputs"),
        "{err}"
    );
}
