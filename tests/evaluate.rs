//! The `evaluate` stage: criteria between synthesized references and
//! candidates with known answers (identical → MAC = FRAC = CSF = 1, NFD = 0;
//! a perturbed model → errors that match its perturbation); the pairing's
//! leftovers on crafted modes (a missed mode, a spurious one, two candidate
//! modes at nearly one frequency) listed in metrics.json, pairs.csv and the
//! report.

use crate::util;

use modalflow::artifacts::metrics::{Metrics, ModeRef};
use util::Workspace;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines/models");

const PIPELINE: &str = r#"name: ev
stages:
  truth:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}
  disturbed:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, values: {k12.k_x: 1.8e6}}
  same:
    kind: evaluate
    inputs: {reference: truth.modes, candidate: truth.modes, reference_frf: truth.frf, candidate_frf: truth.frf, truth: truth.truth, estimate: truth.truth}
  off:
    kind: evaluate
    inputs: {reference: truth.modes, candidate: disturbed.modes, reference_frf: truth.frf, candidate_frf: disturbed.frf, truth: truth.truth, estimate: disturbed.truth}
"#;

fn metrics(ws: &Workspace, stage: &str) -> serde_json::Value {
    ws.json(&format!("results/ev/{stage}/metrics.json"))
}

#[test]
fn identical_models_score_perfectly_and_a_disturbed_one_does_not() {
    let ws = Workspace::new();
    std::fs::copy(
        format!("{MODELS}/three_mass.yaml"),
        ws.path().join("three_mass.yaml"),
    )
    .unwrap();
    ws.write("p.yaml", PIPELINE);
    ws.run(&[], 0);
    let same = metrics(&ws, "same");
    assert_eq!(same["modes"]["paired"], 3);
    assert!((same["modes"]["mean_mac"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert_eq!(same["modes"]["mean_nfd"], 0.0);
    assert!((same["frf"]["mean_frac"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!((same["frf"]["mean_csf"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert_eq!(same["parameters"]["max_abs_relative_error"], 0.0);

    let off = metrics(&ws, "off");
    assert_eq!(
        off["modes"]["paired"], 3,
        "a 20 % stiffer spring keeps modes pairable"
    );
    let nfd = off["modes"]["mean_nfd"].as_f64().unwrap();
    assert!(nfd > 1e-3 && nfd < 0.1, "{nfd}");
    assert!(off["frf"]["mean_frac"].as_f64().unwrap() < 0.99);
    // Exactly one parameter differs, by 1.8e6 / 1.5e6 - 1 = 20 %.
    let errors = ws.read("results/ev/off/tables/parameter_errors.csv");
    let row = errors.lines().find(|l| l.starts_with("k12.k_x,")).unwrap();
    let rel: f64 = row.split(',').nth(3).unwrap().parse().unwrap();
    assert!((rel - 0.2).abs() < 1e-12, "{row}");
    assert!(
        (off["parameters"]["max_abs_relative_error"]
            .as_f64()
            .unwrap()
            - 0.2)
            .abs()
            < 1e-12
    );
    let pairs = ws.read("results/ev/off/tables/pairs.csv");
    assert_eq!(pairs.lines().count(), 4);
    let svg = ws.read("results/ev/off/plots/mac_0.svg");
    assert!(svg.starts_with("<svg") && svg.contains("MAC, position 0"));
    assert!(ws
        .read("results/ev/off/plots/frf_0.svg")
        .contains("<polyline"));
}

#[test]
fn evaluate_needs_something_to_compare() {
    let ws = Workspace::new();
    std::fs::copy(
        format!("{MODELS}/three_mass.yaml"),
        ws.path().join("three_mass.yaml"),
    )
    .unwrap();
    ws.write("p.yaml", "name: ev\nstages:\n  truth:\n    kind: synthesize\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 1}}\n  e:\n    kind: evaluate\n    inputs: {reference: truth.modes}\n");
    // Found at validation (issue 15), before anything runs.
    let out = ws.cmd(&["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(util::text(&out.stderr).contains("stage `e`: nothing to compare"));
    assert!(!ws.path().join("cache/runs").exists());
    ws.write(
        "p.yaml",
        "name: ev\nstages:\n  e:\n    kind: evaluate\n    params: {window: -1}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(util::text(&out.stderr).contains("param `window` = -1 is out of range > 0"));
    ws.write(
        "p.yaml",
        "name: ev\nstages:\n  e:\n    kind: evaluate\n    params: {frequency_scale: 0}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    let err = util::text(&out.stderr);
    assert!(
        err.contains("param `frequency_scale` = 0 is out of range > 0"),
        "{err}"
    );
}

#[test]
fn updated_model_frfs_with_the_initial_model_overlaid() {
    // An "identified" parameter table fed back into synthesize re-solves the
    // model; evaluate then shows reference, initial and updated FRFs.
    let ws = Workspace::new();
    std::fs::copy(
        format!("{MODELS}/three_mass.yaml"),
        ws.path().join("three_mass.yaml"),
    )
    .unwrap();
    ws.write(
        "p.yaml",
        &PIPELINE.replace(
            "  same:\n",
            r#"  updated:
    kind: synthesize
    inputs: {values: truth.truth}
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, values: {k12.k_x: 1.8e6}}
  score:
    kind: evaluate
    inputs: {reference_frf: truth.frf, candidate_frf: updated.frf, initial_frf: disturbed.frf}
  same:
"#,
        ),
    );
    ws.run(&[], 0);
    let m = metrics(&ws, "score");
    // The table overrides the `values` param: the updated model is the truth.
    assert!(
        (m["frf"]["mean_frac"].as_f64().unwrap() - 1.0).abs() < 1e-12,
        "{m}"
    );
    let initial = m["frf"]["initial_mean_frac"].as_f64().unwrap();
    assert!(initial < 0.99, "{m}");
    assert_eq!(
        initial,
        metrics(&ws, "off")["frf"]["mean_frac"].as_f64().unwrap()
    );
    let svg = ws.read("results/ev/score/plots/frf_0.svg");
    assert!(
        svg.contains("initial") && svg.contains("candidate"),
        "overlay"
    );
    // A table naming an unknown parameter is refused with the input named.
    ws.write("bad.csv", "parameter,value\nk99,1\n");
    ws.write(
        "p.yaml",
        "name: ev\nstages:\n  t:\n    kind: command\n    params: {cmd: \"cp bad.csv out.csv\", deps: [bad.csv], outs: [out.csv]}\n  u:\n    kind: synthesize\n    inputs: {values: t.out.csv}\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}\n",
    );
    let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
    assert_eq!(out.status.code(), Some(1));
    let err = util::text(&out.stdout) + &util::text(&out.stderr);
    assert!(
        err.contains("input `values`: the model has no parameter `k99`"),
        "{err}"
    );
}

/// Reference: three modes at 10, 20, 30 Hz with orthogonal shapes on three
/// DOFs. Candidate: mode 1 found; nothing like the 20 Hz mode (a 21 Hz mode
/// with mode 1's shape stands in its window but not its shape: spurious);
/// two modes at 29.9 and 30.1 Hz with mode 3's shape (either could be it).
const REFERENCE_MODES: &str = "mode,frequency_hz,damping_ratio\n1,10,0.01\n2,20,0.01\n3,30,0.01\n";
const REFERENCE_SHAPES: &str = "mode,node,direction,real,imag\n\
    1,1,+X,1,0\n1,2,+X,0,0\n1,3,+X,0,0\n\
    2,1,+X,0,0\n2,2,+X,1,0\n2,3,+X,0,0\n\
    3,1,+X,0,0\n3,2,+X,0,0\n3,3,+X,1,0\n";
const CANDIDATE_MODES: &str =
    "mode,frequency_hz,damping_ratio\n1,10.05,0.01\n2,21,0.01\n3,29.9,0.01\n4,30.1,0.01\n";
const CANDIDATE_SHAPES: &str = "mode,node,direction,real,imag\n\
    1,1,+X,1,0\n1,2,+X,0.01,0\n1,3,+X,0,0\n\
    2,1,+X,1,0\n2,2,+X,0,0\n2,3,+X,0,0\n\
    3,1,+X,0,0\n3,2,+X,0,0\n3,3,+X,1,0\n\
    4,1,+X,0,0\n4,2,+X,0.02,0\n4,3,+X,1,0\n";

const CRAFTED: &str = r#"name: pairing
stages:
  modes:
    kind: command
    params: {cmd: "mkdir -p ref cand && cp src/ref/*.csv ref/ && cp src/cand/*.csv cand/", deps: [src], outs: [ref, cand]}
  score:
    kind: evaluate
    inputs: {reference: modes.ref, candidate: modes.cand}
    params: {window: 0.2, min_mac: 0.3}
  strict:
    kind: evaluate
    inputs: {reference: modes.ref, candidate: modes.cand}
    params: {window: 0.2, min_mac: 0.3, ambiguity: 0}
  report:
    kind: report
    inputs: {metrics: [score.metrics]}
"#;

#[test]
fn missed_spurious_and_ambiguous_modes_are_listed() {
    let ws = Workspace::new();
    ws.write("src/ref/modes.csv", REFERENCE_MODES);
    ws.write("src/ref/mode_shapes.csv", REFERENCE_SHAPES);
    ws.write("src/cand/modes.csv", CANDIDATE_MODES);
    ws.write("src/cand/mode_shapes.csv", CANDIDATE_SHAPES);
    ws.write("p.yaml", CRAFTED);
    ws.run(&[], 0);
    let read =
        |stage: &str| -> Metrics { ws.json(&format!("results/pairing/{stage}/metrics.json")) };
    let m = read("score");
    let modes = m.modes.as_ref().unwrap();
    assert_eq!(
        (modes.paired, modes.reference_modes, modes.candidate_modes),
        (2, 3, 4)
    );
    assert_eq!(
        (
            modes.unpaired_reference,
            modes.unpaired_candidate,
            modes.ambiguous
        ),
        (1, 2, 1)
    );
    let p = &modes.positions[0];
    assert_eq!(
        p.unpaired_reference,
        [ModeRef {
            mode: 2,
            frequency_hz: 20.0
        }],
        "the 20 Hz mode is missed, not stood in for by the 21 Hz one"
    );
    // 29.9 Hz is nearer 30 Hz than 30.1 Hz only by NFD, with a hair better
    // MAC: it is taken, 30.1 Hz is left over, and the pair is ambiguous.
    let spurious: Vec<usize> = p.unpaired_candidate.iter().map(|m| m.mode).collect();
    assert_eq!(spurious, [2, 4]);
    assert_eq!(p.unpaired_candidate[0].frequency_hz, 21.0);
    let a = &p.ambiguous[0];
    assert_eq!((a.reference_mode, a.candidate_mode), (3, 3));
    assert_eq!((a.rival_candidate, a.rival_reference), (Some(4), None));
    assert!(a.margin >= 0.0 && a.margin < 0.01, "{a:?}");
    let pairs = ws.read("results/pairing/score/tables/pairs.csv");
    assert!(pairs
        .lines()
        .next()
        .unwrap()
        .ends_with(",MAC,MACXP,cost,margin,ambiguous"));
    let flags: Vec<&str> = pairs
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(flags, ["false", "true"], "{pairs}");
    // The ambiguity threshold is a param: at 0 nothing is ambiguous.
    let strict = read("strict");
    assert_eq!(strict.modes.as_ref().unwrap().ambiguous, 0);
    assert!(ws
        .read("results/pairing/strict/tables/pairs.csv")
        .lines()
        .skip(1)
        .all(|l| l.ends_with(",false")));
    // The report names each leftover by number and frequency.
    let md = ws.read("results/pairing/report/report/report.md");
    for expected in [
        "| score | 2/3 | **✗ 1** | **✗ 2** | **✗ 1** |",
        "score, position 0: reference mode(s) 2 (20.0000 Hz) have no candidate partner (missed)",
        "candidate mode(s) 2 (21.0000 Hz), 4 (30.1000 Hz) have no reference partner",
        "reference 3 (30.0000 Hz) ↔ candidate 3 (29.9000 Hz) is ambiguous",
        "rival candidate 4",
    ] {
        assert!(md.contains(expected), "missing `{expected}` in\n{md}");
    }
}

/// A receptance reference against an accelerance candidate (the normal
/// case: a model in receptance, accelerometers measuring) is compared in
/// receptance after converting by (jω)⁻²: its FRAC and CSF equal those of
/// the same candidate synthesized in receptance, to 1e-12, and the
/// conversion is stated. With the model as geometry, the paired modes are
/// drawn on the structure.
#[test]
fn mixed_quantities_are_converted_and_state_it() {
    let ws = Workspace::new();
    std::fs::copy(
        format!("{MODELS}/three_mass.yaml"),
        ws.path().join("three_mass.yaml"),
    )
    .unwrap();
    ws.write(
        "p.yaml",
        r#"name: ev
stages:
  truth:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 1, max: 400, step: 0.5}}
  rec:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 1, max: 400, step: 0.5}, values: {k12.k_x: 1.8e6}}
  acc:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 1, max: 400, step: 0.5}, values: {k12.k_x: 1.8e6}, quantity: accelerance}
  same:
    kind: evaluate
    inputs: {reference_frf: truth.frf, candidate_frf: rec.frf}
  mixed:
    kind: evaluate
    inputs: {reference_frf: truth.frf, candidate_frf: acc.frf, reference: truth.modes, candidate: acc.modes, geometry: truth.model}
"#,
    );
    ws.run(&[], 0);
    let (same, mixed) = (metrics(&ws, "same"), metrics(&ws, "mixed"));
    for key in ["mean_frac", "mean_csf"] {
        let (a, b) = (
            same["frf"][key].as_f64().unwrap(),
            mixed["frf"][key].as_f64().unwrap(),
        );
        assert!((a - b).abs() <= 1e-12, "{key}: {a} vs {b}");
        assert!(a < 0.999, "the disturbed model differs: {key} {a}");
    }
    assert_eq!(mixed["frf"]["quantity"], "receptance");
    let note = mixed["frf"]["conversions"][0].as_str().unwrap();
    assert!(
        note.contains("accelerance converted to receptance by (jω)^-2"),
        "{note}"
    );
    assert!(same["frf"]["conversions"].as_array().unwrap().is_empty());
    let plots = ws.path().join("results/ev/mixed/plots");
    let shapes = std::fs::read_to_string(plots.join("shapes_0.svg")).unwrap();
    assert_eq!(shapes.matches(">MAC ").count(), 3, "one row per pair");
    let frf = std::fs::read_to_string(plots.join("frf_0.svg")).unwrap();
    assert!(frf.contains("|H| [m/N]") && frf.contains("phase [°]"));
    for svg in [
        &shapes,
        &frf,
        &std::fs::read_to_string(plots.join("mac_0.svg")).unwrap(),
    ] {
        let problems = modalflow::report::lint::check(svg);
        assert!(problems.is_empty(), "{problems:?}");
    }
}
