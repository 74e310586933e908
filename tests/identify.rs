//! The `identify` stage in pipelines: synthesize a truth with known
//! stiffness, identify it back from the file's nominal start, evaluate the
//! estimate against the truth; the guided strategy on a gsa screening
//! (PUB3 scenario 1 on the three-mass model: the CI-sized variant of
//! pipelines/identification_comparison.yaml); bad params rejected before
//! anything runs.

use crate::util;
use modalflow::identify::verdict::{Fit, Verdict};
use modalflow::identify::FollowUpKind;

use util::Workspace;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines/models");

const PIPELINE: &str = r#"name: id
stages:
  truth:
    kind: synthesize
    params:
      model: three_mass.yaml
      frequency: {min: 0, max: 400, step: 0.5}
      values: {k1.k_x: 2.4e6, k12.k_x: 1.3e6, k23.k_x: 1.15e6, k3.k_x: 4.2e5}
  fit:
    kind: identify
    inputs: {model: truth.model, reference: truth.modes}
    params: {strategy: black_box, optimizer: slsqp, budget: 3000, window: 0.3}
  check:
    kind: evaluate
    inputs: {truth: truth.truth, estimate: fit.parameters, reference: truth.modes, candidate: fit.updated_modes}
  screen:
    kind: gsa
    inputs: {reference: truth.modes}
    params: {model: three_mass.yaml, samples: 64, bootstrap: 10, threshold: 0.1, window: 0.3}
  guided:
    kind: identify
    inputs: {reference: truth.modes, sensitivity: screen.subproblems}
    params: {model: three_mass.yaml, strategy: sensitivity_guided, budget: 600, repeats: 2, window: 0.3, seed: 3}
  check_guided:
    kind: evaluate
    inputs: {truth: truth.truth, estimate: guided.parameters, reference: truth.modes, candidate: guided.updated_modes}
"#;

fn setup(pipeline: &str) -> Workspace {
    let ws = Workspace::new();
    std::fs::copy(
        format!("{MODELS}/three_mass.yaml"),
        ws.path().join("three_mass.yaml"),
    )
    .unwrap();
    ws.write("p.yaml", pipeline);
    ws
}

#[test]
fn black_box_and_guided_recover_the_synthesized_stiffness() {
    let ws = setup(PIPELINE);
    let report = ws.run(&[], 0);
    assert!(report.all("ran"), "{:?}", report.statuses());
    let stiffness_errors = |stage: &str| -> Vec<f64> {
        let errors = ws.read(&format!("results/id/{stage}/tables/parameter_errors.csv"));
        ["k1.k_x", "k12.k_x", "k23.k_x", "k3.k_x"]
            .iter()
            .map(|name| {
                let row = errors
                    .lines()
                    .find(|l| l.starts_with(&format!("{name},")))
                    .unwrap();
                row.split(',').nth(3).unwrap().parse::<f64>().unwrap().abs()
            })
            .collect()
    };
    for rel in stiffness_errors("check") {
        assert!(rel < 0.01, "black-box SLSQP: {rel}");
    }
    let metrics: serde_json::Value = ws.json("results/id/check/metrics.json");
    assert_eq!(metrics["modes"]["paired"], 3);
    assert!(metrics["modes"]["mean_mac"].as_f64().unwrap() > 0.9999);
    let cost = ws.cost("results/id/fit");
    assert!(cost.evaluations <= 3000);
    // Every evaluation is in one phase.
    assert_eq!(cost.phase_evaluations.total(), cost.evaluations, "{cost:?}");
    assert!(cost.phase_evaluations.optimizer > 0, "{cost:?}");
    assert!(cost.best_objective < 1e-4);
    assert_eq!(cost.optimizer, "slsqp");
    let params = ws.read("results/id/fit/parameters.csv");
    assert!(params.starts_with(
        "parameter,value,lower,upper,initial,identified,identifiable,std_error_rel,std_error_with_fixed_rel,ci_low,ci_high,score,implicated,suggested_change_rel\n"
    ));
    // The start is the model file's nominal value; exact data determine
    // every stiffness: a standard error and an interval around the value.
    let k1 = util::csv_row(&params, "k1.k_x");
    assert_eq!(k1[4], "2000000.0");
    assert_eq!((k1[5], k1[6]), ("true", "true"));
    let (v, lo, hi): (f64, f64, f64) = (
        k1[1].parse().unwrap(),
        k1[9].parse().unwrap(),
        k1[10].parse().unwrap(),
    );
    assert!(lo <= v && v <= hi && (hi - lo) < 0.01 * v, "{k1:?}");
    // The verdict: converged, within the noise, every mode paired.
    assert!(cost.verdict.ok, "{:?}", cost.verdict);
    assert_eq!(cost.verdict.modes.unpaired, 0);
    let correlation = ws.read("results/id/fit/correlation.csv");
    assert_eq!(correlation.lines().count(), 4, "{correlation}");
    assert!(
        correlation.lines().skip(1).all(|l| l.contains(",true,")),
        "{correlation}"
    );
    let id: serde_json::Value = ws.json("results/id/fit/identifiability.json");
    assert!(id["parameters"].as_array().unwrap().len() == 8, "{id}");
    let history = ws.read("results/id/fit/history.csv");
    assert!(
        history.starts_with("evaluation,best_objective,mean_mac\n") && history.lines().count() > 2
    );

    // Guided (scenario 1: the model differs from the truth only in the
    // identified stiffness): exact to 1e-6 within the 600-evaluation budget.
    for rel in stiffness_errors("check_guided") {
        assert!(rel < 1e-6, "guided: {rel}");
    }
    let detail: serde_json::Value = ws.json("results/id/guided/subproblems.json");
    assert!(!detail["subproblems"].as_array().unwrap().is_empty());
    assert!(detail["refinement"][0]["end"].as_f64().unwrap() < 1e-12);
    let guided = ws.cost("results/id/guided");
    assert_eq!(guided.strategy, "sensitivity_guided");
    assert!(guided.evaluations <= 600);
    assert_eq!(guided.phase_evaluations.total(), guided.evaluations);
    assert!(guided.modes.mean_mac > 1.0 - 1e-9);
    assert!(guided.modes.mean_nfd < 1e-6);
    assert!(guided.verdict.ok, "{:?}", guided.verdict);
    let history = ws.read("results/id/guided/history.csv");
    assert!(history.starts_with("evaluation,best_objective,mean_mac\n"));
    // Cached: a second run executes nothing.
    assert!(ws.run(&[], 0).all("cached"));
}

fn rejected(params: &str, expect: &str) {
    let ws = setup(&format!(
        "name: bad\nstages:\n  truth:\n    kind: synthesize\n    params: {{model: three_mass.yaml, frequency: {{min: 0, max: 400, step: 0.5}}}}\n  fit:\n    kind: identify\n    inputs: {{model: truth.model, reference: truth.modes}}\n    params: {params}\n"
    ));
    let out = ws.cmd(&["run", "p.yaml"]);
    let err = util::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(expect), "{err}");
    assert!(!ws.path().join("results").exists());
}

#[test]
fn bad_params_are_rejected_before_anything_runs() {
    rejected("{optimizer: nelder_mead}", "optimizer");
    rejected("{budget: 0}", "budget");
    rejected(
        "{optimizer: pso, optimizer_settings: {swarmsize: 3}}",
        "swarm_size",
    );
    rejected("{weights: {mac: -1}}", "weights");
    rejected("{strategy: sensitivity_guided, optimizer: pso}", "slsqp");
    rejected("{exclude_modes: [mode7]}", "p<position>.mode<r>");
    rejected("{guided: {spread_limit: -1}}", "spread_limit");
    rejected("{guided: {repeat: 2}}", "guided");
    // A hit time for a truncation that is off would be silently ignored.
    rejected("{frf_pre_trigger_s: 0.01}", "frf_truncated: true");
    rejected("{shape_observability: -0.1}", "shape_observability");
}

/// `shape_observability` above a mode's sensor amplitude (the median mode's
/// is 1: of three modes, the one below it) compares that mode by its
/// frequency alone, used, with the reason in correlation.csv; unset, every
/// mode is compared in full. The fit still places that mode's frequency.
#[test]
fn a_weakly_seen_mode_counts_by_its_frequency_alone() {
    let ws = setup(&format!(
        "{}  weak:\n    kind: identify\n    inputs: {{model: truth.model, reference: truth.modes}}\n    params: {{strategy: black_box, optimizer: slsqp, budget: 3000, window: 0.3, observability: 0.0, shape_observability: 0.999}}\n",
        &PIPELINE[..PIPELINE.find("  check:").unwrap()]
    ));
    let report = ws.run(&["weak", "fit"], 0);
    assert!(report.all("ran"), "{:?}", report.statuses());
    let weak = ws.read("results/id/weak/correlation.csv");
    let rows: Vec<&str> = weak.lines().skip(1).collect();
    assert_eq!(rows.len(), 3, "{weak}");
    assert!(rows.iter().all(|l| l.contains(",true,")), "{weak}");
    let by_frequency = rows
        .iter()
        .filter(|l| l.contains("frequency only, shape not observable"))
        .count();
    assert_eq!(by_frequency, 1, "{weak}");
    let full = ws.read("results/id/fit/correlation.csv");
    assert!(!full.contains("frequency only"), "{full}");
    // Its frequency is fitted: the model's partner at the result sits on it
    // (reference_hz is the third column, model_hz the fourth from the end;
    // the quoted reason between them holds commas).
    let row = rows.iter().find(|l| l.contains("frequency only")).unwrap();
    let (f_ref, f_model): (f64, f64) = (
        row.split(',').nth(2).unwrap().parse().unwrap(),
        row.rsplit(',').nth(3).unwrap().parse().unwrap(),
    );
    assert!((f_model / f_ref - 1.0).abs() < 1e-4, "{weak}");
}

/// A budget below what the assessment of the result alone costs (2n + 7
/// evaluations for n parameters: 23 for the three-mass model's 8) is a
/// located error at validation when the model file is a param, and a
/// `budget` error (not one of the reference) when it comes from an input.
#[test]
fn a_budget_below_the_assessment_is_refused_at_validation() {
    let ws = setup(
        "name: small\nstages:\n  fit:\n    kind: identify\n    inputs: {reference: truth.modes}\n    params: {model: three_mass.yaml, budget: 22}\n  truth:\n    kind: synthesize\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    let err = util::text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("budget") && err.contains("give at least budget: 23"),
        "{err}"
    );
    ws.write(
        "p.yaml",
        &ws.read("p.yaml").replace("budget: 22", "budget: 23"),
    );
    let out = ws.cmd(&["validate", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    // From the `model` input the model is first seen at run time.
    ws.write(
        "p.yaml",
        "name: small\nstages:\n  truth:\n    kind: synthesize\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}\n  fit:\n    kind: identify\n    inputs: {model: truth.model, reference: truth.modes}\n    params: {budget: 22}\n",
    );
    let out = ws.cmd(&["run", "p.yaml"]);
    let err = util::text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("param `budget`"), "{err}");
}

#[test]
fn guided_without_sensitivity_is_rejected_before_anything_runs() {
    // `Stage::check_inputs` sees which inputs are bound: a validation error.
    let ws = setup(
        "name: g\nstages:\n  truth:\n    kind: synthesize\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}\n  fit:\n    kind: identify\n    inputs: {model: truth.model, reference: truth.modes}\n    params: {strategy: sensitivity_guided}\n",
    );
    let out = ws.cmd(&["run", "p.yaml"]);
    let err = util::text(&out.stderr) + &util::text(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("sensitivity_guided needs the `sensitivity` input"),
        "{err}"
    );
    assert!(!ws.path().join("cache/runs").exists());
}

const FIXTURES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/models");

/// A workspace with the parallel-springs model.
fn parallel(pipeline: &str) -> Workspace {
    let ws = Workspace::new();
    std::fs::copy(
        format!("{FIXTURES}/parallel_springs.yaml"),
        ws.path().join("parallel.yaml"),
    )
    .unwrap();
    ws.write("p.yaml", pipeline);
    ws
}

#[test]
fn parallel_springs_are_named_as_undetermined_and_the_rest_is_identified() {
    // ka and kb act only through their sum: whatever the data, their split
    // is free. The truth moves all three; the identification must fit the
    // modes exactly, determine k12, and name {ka, kb} instead of reporting
    // an arbitrary split as a value with an error bar.
    let ws = parallel(
        "name: par\nstages:\n  truth:\n    kind: synthesize\n    params: {model: parallel.yaml, frequency: {min: 0, max: 300, step: 0.5}, values: {ka.k_x: 1.3e6, kb.k_x: 0.6e6, k12.k_x: 1.0e6}}\n  fit:\n    kind: identify\n    inputs: {reference: truth.modes}\n    params: {model: parallel.yaml, strategy: black_box, optimizer: slsqp, budget: 1500}\n",
    );
    ws.run(&[], 0);
    let id: serde_json::Value = ws.json("results/par/fit/identifiability.json");
    let groups = id["undetermined"].as_array().unwrap();
    let structural: Vec<Vec<&str>> = groups
        .iter()
        .filter(|g| g["singular_value"] == 0.0)
        .map(|g| {
            g["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| p[0].as_str().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(structural, [vec!["ka.k_x", "kb.k_x"]], "{id}");
    let text = id["undetermined_text"].to_string();
    assert!(
        text.contains("{ka.k_x, kb.k_x}: 1 free combination"),
        "{text}"
    );
    let params = ws.read("results/par/fit/parameters.csv");
    let row = |name: &str| -> Vec<String> {
        params
            .lines()
            .find(|l| l.starts_with(&format!("{name},")))
            .unwrap()
            .split(',')
            .map(String::from)
            .collect()
    };
    // Not identifiable: flagged, no error bar.
    for name in ["ka.k_x", "kb.k_x"] {
        let r = row(name);
        assert_eq!((r[6].as_str(), r[7].as_str()), ("false", ""), "{r:?}");
    }
    // Identifiable and right; the sum of the pair is right too.
    let k12 = row("k12.k_x");
    assert_eq!(k12[6], "true", "{k12:?}");
    assert!(
        (k12[1].parse::<f64>().unwrap() / 1.0e6 - 1.0).abs() < 1e-4,
        "{k12:?}"
    );
    let sum = row("ka.k_x")[1].parse::<f64>().unwrap() + row("kb.k_x")[1].parse::<f64>().unwrap();
    assert!((sum / 1.9e6 - 1.0).abs() < 1e-4, "{sum}");
    let warnings = ws.cost("results/par/fit").verdict.warnings;
    assert!(
        warnings.iter().any(|w| w.contains("not determined")),
        "{warnings:?}"
    );
}

/// `heavy.yaml`: the three-mass chain with other masses, a model error no
/// stiffness can absorb.
fn write_heavy(ws: &Workspace) {
    let heavy = std::fs::read_to_string(format!("{MODELS}/three_mass.yaml"))
        .unwrap()
        .replace("mass: 1.0,", "mass: 2.6,")
        .replace("mass: 0.8,", "mass: 0.3,");
    ws.write("heavy.yaml", &heavy);
}

#[test]
fn a_model_that_cannot_match_says_so() {
    // The reference comes from the three-mass chain with its masses changed
    // (a model error no stiffness can absorb): the update must end with a
    // verdict that is not ok, the residual above the noise and the size of
    // the misfit — and exit 0 with results, as the data deserve.
    let ws = setup(
        "name: bad\nstages:\n  truth:\n    kind: synthesize\n    params: {model: heavy.yaml, frequency: {min: 0, max: 400, step: 0.5}}\n  fit:\n    kind: identify\n    inputs: {reference: truth.modes}\n    params: {model: three_mass.yaml, strategy: black_box, optimizer: slsqp, budget: 1500}\n",
    );
    write_heavy(&ws);
    ws.run(&[], 0);
    let v = ws.cost("results/bad/fit").verdict;
    assert!(!v.ok, "{v:?}");
    assert_eq!(v.fit, Fit::AboveNoise, "{v:?}");
    assert!(v.end_rms > 2.0, "{v:?}");
    assert!(
        v.message.contains("above the reference's uncertainty"),
        "{v:?}"
    );
}

/// The updated model file: the input model with the identified values (and
/// a comment per parameter), bounds unchanged; synthesized again it gives
/// the identification's `updated_modes` (frequencies to 1e-12).
#[test]
fn the_updated_model_file_reproduces_the_updated_modes() {
    let ws = setup(
        "name: um\nstages:\n  truth:\n    kind: synthesize\n    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, values: {k1.k_x: 2.4e6, k12.k_x: 1.3e6}}\n  fit:\n    kind: identify\n    inputs: {model: truth.model, reference: truth.modes}\n    params: {strategy: black_box, optimizer: slsqp, budget: 800, window: 0.3}\n",
    );
    ws.run(&[], 0);
    let dir = "results/um/fit/updated_model";
    let yaml = ws.read(&format!("{dir}/model.yaml"));
    assert!(
        yaml.starts_with("# Updated model: three_mass.yaml"),
        "{yaml}"
    );
    assert!(
        yaml.contains("# k1.k_x: initial 2e6, identified "),
        "{yaml}"
    );
    assert!(
        yaml.contains("lower: 5.0e5, upper: 8.0e6"),
        "bounds unchanged: {yaml}"
    );
    let changes = ws.read(&format!("{dir}/changes.csv"));
    assert!(changes.starts_with("parameter,kind,initial,value,change_rel,identified,"));
    assert_eq!(changes.lines().count(), 1 + 8);
    ws.write(
        "p.yaml",
        &format!("name: um2\nstages:\n  again:\n    kind: synthesize\n    params: {{model: {dir}/model.yaml, frequency: {{min: 0, max: 400, step: 0.5}}}}\n"),
    );
    ws.run(&[], 0);
    crate::util::assert_same_frequencies(
        &ws.frequencies("results/um/fit/modes/modes.csv"),
        &ws.frequencies("results/um2/again/modes/modes.csv"),
        3,
    );
}

/// The measured FRFs as the final reference (`frf` input): on the
/// three-mass chain measured with 1 % noise the FRF refinement ends at the
/// noise (RMS ≈ 1σ) and the verdict is ok; on a chain with other masses (a
/// model error) it ends far above the noise with a smooth residual, and the
/// verdict says so.
#[test]
fn measured_frfs_refine_the_update_and_judge_it() {
    let values = "{k1.k_x: 2.4e6, k12.k_x: 1.3e6, k23.k_x: 1.15e6, k3.k_x: 4.2e5, k1.c_x: 48, k12.c_x: 25, k23.c_x: 23, k3.c_x: 12}";
    let ws = setup(&format!(
        "name: frf\nstages:\n  truth:\n    kind: synthesize\n    params: {{model: three_mass.yaml, frequency: {{min: 10, max: 400, step: 0.5}}, values: {values}, noise: {{relative: 0.01}}, seed: 2}}\n  heavy:\n    kind: synthesize\n    params: {{model: heavy.yaml, frequency: {{min: 10, max: 400, step: 0.5}}, noise: {{relative: 0.01}}, seed: 2}}\n  fit:\n    kind: identify\n    inputs: {{reference: truth.modes, frf: truth.frf}}\n    params: {{model: three_mass.yaml, strategy: black_box, optimizer: slsqp, budget: 3000}}\n  bad:\n    kind: identify\n    inputs: {{reference: heavy.modes, frf: heavy.frf}}\n    params: {{model: three_mass.yaml, strategy: black_box, optimizer: slsqp, budget: 6000}}\n"
    ));
    write_heavy(&ws);
    ws.run(&[], 0);
    let good = ws.cost("results/frf/fit");
    let frf = good
        .frf
        .as_ref()
        .expect("an FRF summary with the frf input");
    assert!((0.8..1.3).contains(&frf.end.rms), "{frf:?}");
    assert!(frf.evaluations > 0, "{frf:?}");
    assert!(good.evaluations <= 3000, "{good:?}");
    let v = &good.verdict;
    assert!(v.ok, "{v:?}");
    let judged = |v: &Verdict| v.frf.expect("an FRF judgement");
    assert_eq!(judged(v).fit, Fit::WithinNoise, "{v:?}");
    assert!(v.message.contains("FRF residual"), "{v:?}");
    assert_eq!(good.phase_evaluations.total(), good.evaluations, "{good:?}");
    assert!(good.follow_ups.is_empty(), "{good:?}");
    // Above the noise with every parameter identified, and a resonance
    // far above it (the heavy masses shift every mode): the search of that
    // window ran first, then the escape search, out of the same budget,
    // and cost.json accounts for both.
    let bad = ws.cost("results/frf/bad");
    assert_eq!(bad.phase_evaluations.total(), bad.evaluations, "{bad:?}");
    assert!(bad.evaluations <= 6000, "{}", bad.evaluations);
    let kinds: Vec<FollowUpKind> = bad.follow_ups.iter().map(|f| f.kind).collect();
    assert_eq!(
        kinds,
        [FollowUpKind::Window, FollowUpKind::Escape],
        "{bad:?}"
    );
    for f in &bad.follow_ups {
        assert!(f.evaluations > 0 && f.rms_after.is_finite(), "{f:?}");
    }
    let spent: usize = bad.follow_ups.iter().map(|f| f.evaluations).sum();
    assert_eq!(bad.phase_evaluations.follow_ups, spent);
    let v = bad.verdict;
    assert!(!v.ok, "{v:?}");
    assert_eq!(judged(&v).fit, Fit::AboveNoise, "{v:?}");
    assert!(judged(&v).end.rms > 5.0, "{v:?}");
    assert!(v.message.contains("systematic"), "{v:?}");
}

/// An impact test's FRFs carry coherence: with `frf_averages` each line's
/// noise comes from it (cost.json says so, and the truth's own model fits
/// at the noise); without, the coherence left unused is a warning.
#[test]
fn impact_test_frfs_are_weighted_by_their_coherence() {
    let fit = |name: &str, extra: &str| {
        format!("  {name}:\n    kind: identify\n    inputs: {{reference: truth.modes, frf: truth.frf}}\n    params: {{model: three_mass.yaml, strategy: black_box, optimizer: slsqp, budget: 1500{extra}}}\n")
    };
    let ws = setup(&format!(
        "name: hammer\nstages:\n  truth:\n    kind: synthesize\n    params: {{model: three_mass.yaml, frequency: {{min: 10, max: 400, step: 0.25}}, impact_test: {{averages: 5, response_noise: 0.002, force_noise: 0.01}}, seed: 3}}\n{}{}",
        fit("coherent", ", frf_averages: 5"),
        fit("lines", "")
    ));
    ws.run(&[], 0);
    let coherent = ws.cost("results/hammer/coherent");
    let frf = coherent.frf.as_ref().expect("an FRF summary");
    assert!(frf.noise.starts_with("coherence (n = 5)"), "{frf:?}");
    assert!(
        !coherent
            .verdict
            .warnings
            .iter()
            .any(|w| w.contains("frf_averages")),
        "{:?}",
        coherent.verdict.warnings
    );
    let lines = ws.cost("results/hammer/lines");
    let unused = lines.frf.as_ref().expect("an FRF summary");
    assert!(unused.noise.starts_with("fourth differences"), "{unused:?}");
    assert!(
        lines
            .verdict
            .warnings
            .iter()
            .any(|w| w.contains("frf_averages")),
        "{:?}",
        lines.verdict.warnings
    );
    // The coherence's σ is the larger (it holds the noise smooth along
    // frequency), so the same data give a smaller residual in σ units.
    assert!(frf.end.rms < unused.end.rms, "{frf:?} vs {unused:?}");
}
