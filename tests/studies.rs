//! CI-sized variants of the shipped studies in `pipelines/`: each pipeline
//! file is copied with its models, shrunk by a few textual edits (fewer
//! samples, levels or seeds; every edit must apply, so a changed study fails
//! here rather than silently running full size) and run end to end; the
//! assertions check the study's headline result, not only that it ran.

use crate::util;

use serde_json::Value;
use util::study;

fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn wear_monitoring_localizes_wear_by_mode() {
    let ws = study(
        "wear_monitoring",
        &[
            (
                "matrix: {bsd: [1.0, 0.7, 0.4], lgs: [1.0, 0.7, 0.4], repeat: [1, 2]}\n    params:\n      model",
                "matrix: {bsd: [1.0, 0.4], lgs: [1.0, 0.4], repeat: [1, 2]}\n    params:\n      model",
            ),
            (
                "matrix: {bsd: [1.0, 0.7, 0.4], lgs: [1.0, 0.7, 0.4], repeat: [1, 2]}\n    inputs",
                "matrix: {bsd: [1.0, 0.4], lgs: [1.0, 0.4], repeat: [1, 2]}\n    inputs",
            ),
        ],
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("anova")["counters"]["runs"], 8);
    // Share of the sum of squares of `source` in `output`'s ANOVA.
    let share = |stage: &str, output: &str, source: &str| -> f64 {
        let rows = csv_rows(&ws.read(&format!("results/wear_monitoring/{stage}/anova.csv")));
        let of = |s: &str| -> f64 {
            rows.iter()
                .find(|r| r[0] == output && r[1] == s)
                .unwrap_or_else(|| panic!("{stage}: no {output} {s}"))[2]
                .parse()
                .unwrap()
        };
        let total: f64 = rows
            .iter()
            .filter(|r| r[0] == output)
            .map(|r| r[2].parse::<f64>().unwrap())
            .sum();
        of(source) / total
    };
    // The model: the first mode is the guides' alone, the second the ball screw's.
    assert!(share("model_anova", "p1.mode1.frequency", "lgs") > 0.99);
    assert!(share("model_anova", "p1.mode2.frequency", "bsd") > 0.9);
    // AutoEMA on noisy FRFs of each state sees the same.
    assert!(share("anova", "p1.mode1.frequency", "lgs") > 0.5);
    assert!(share("anova", "p1.mode2.frequency", "bsd") > 0.8);
    assert!(util::assert_report_figures(&ws, "wear_monitoring") >= 3);
    let html = ws.read("results/wear_monitoring/report/report/index.html");
    assert!(
        html.contains("<h2 id=\"model-anova-anova\">model_anova.anova</h2>"),
        "report lacks the tables"
    );
}

#[test]
fn autoema_study_finds_the_modes() {
    let ws = study(
        "autoema_study",
        &[("iterations: 40, initial: 12", "iterations: 16, initial: 8")],
    );
    ws.run(&[], 0);
    let m: Value = ws.json("results/autoema_study/score/metrics.json");
    let paired = m["modes"]["paired"].as_u64().unwrap();
    assert!(paired >= 30, "{m}");
    assert!(m["modes"]["mean_mac"].as_f64().unwrap() > 0.9, "{m}");
    assert!(m["frf"]["mean_frac"].as_f64().unwrap() > 0.95, "{m}");
    // The stabilization diagram; MAC, FRF overlay and mode shapes per position.
    assert!(util::assert_report_figures(&ws, "autoema_study") >= 13);
}

#[test]
fn dimensionality_reduction_splits_and_validates() {
    let ws = study(
        "dimensionality_reduction",
        &[
            ("matrix: {seed: [3, 4]}", "matrix: {seed: [3]}"),
            ("samples: 128", "samples: 8"),
            ("bootstrap: 100", "bootstrap: 10"),
            ("validation: 1000", "validation: 40"),
            ("positions: [0, 2, 3]", "positions: [0]"),
        ],
    );
    ws.run(&[], 0);
    let dir = "results/dimensionality_reduction/gsa[seed=3]";
    let significant = ws.read(&format!("{dir}/significant.csv"));
    let flagged = significant.lines().filter(|l| l.ends_with(",true")).count();
    assert!(flagged > 3 && flagged < 78, "{significant}");
    let v: Value = ws.json(&format!("{dir}/validation.json"));
    assert_eq!(v["samples"], 40);
    let (min, mean) = (v["min"].as_f64().unwrap(), v["mean"].as_f64().unwrap());
    assert!(min <= mean && mean > 0.8 && mean <= 1.0, "{v}");
    let md = ws.read("results/dimensionality_reduction/report/report/report.md");
    assert!(md.contains("Validation of the split"), "{md}");
    assert!(util::assert_report_figures(&ws, "dimensionality_reduction") >= 2);
}

#[test]
fn identification_comparison_runs_end_to_end_within_budgets() {
    // Accuracy is asserted on small models in tests/identify.rs; here the
    // study's wiring: screening, both scenarios, ablations, black-box runs,
    // scores and the report, each identification within its budget.
    let ws = study(
        "identification_comparison",
        &[
            ("samples: 64", "samples: 8"),
            ("bootstrap: 50", "bootstrap: 5"),
            ("budget: 6000", "budget: 1200"),
            ("budget: 20000", "budget: 400"),
            (
                "matrix: {optimizer: [pso, ga], seed: [1, 2, 3]}",
                "matrix: {optimizer: [pso, ga], seed: [1]}",
            ),
        ],
    );
    let report = ws.run(&[], 0);
    // Stages with byte-identical inputs (two ablations that end at one
    // point) share one result: ran or cached, never failed.
    assert!(
        report
            .statuses()
            .iter()
            .all(|(_, s)| s == "ran" || s == "cached"),
        "{:?}",
        report.statuses()
    );
    for (stage, budget) in [
        ("guided[scenario=truth]", 1200),
        ("refine_only", 1200),
        ("black_box[optimizer=pso,seed=1]", 400),
        ("black_box_slsqp", 400),
    ] {
        let c = ws.cost(&format!("results/identification_comparison/{stage}"));
        // Every evaluation counts, the assessment of the result included.
        assert!(
            c.evaluations > 0 && c.evaluations <= budget,
            "{stage}: {c:?}"
        );
        // A verdict is always written.
        assert!(!c.verdict.message.is_empty(), "{stage}: {c:?}");
    }
    let md = ws.read("results/identification_comparison/report/report/report.md");
    assert!(md.contains("guided[scenario=disturbed]"), "{md}");
    assert!(util::assert_report_figures(&ws, "identification_comparison") >= 2);
}

#[test]
fn model_updating_updates_from_measured_modes_and_reports() {
    let ws = study(
        "model_updating",
        &[
            ("samples: 64", "samples: 8"),
            ("bootstrap: 50", "bootstrap: 5"),
            // The modal continuation may use half of it before the FRF
            // refinement over the identified parameters.
            ("budget: 8000", "budget: 3000"),
            ("budget: 20000\n  ga", "budget: 200\n  ga"),
            ("budget: 20000\n  updated", "budget: 200\n  updated"),
        ],
    );
    let r = ws.run(&[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    // The updated model file of every identification loads as a model.
    for run in ["guided", "pso", "ga"] {
        let yaml = ws.read(&format!(
            "results/model_updating/{run}/updated_model/model.yaml"
        ));
        modalflow::dynamics::model_file::parse(&yaml, "model.yaml").unwrap();
    }
    // MAC, FRF overlay and mode shapes per position and run, convergence,
    // parameter errors, the stabilization diagrams.
    assert!(util::assert_report_figures(&ws, "model_updating") >= 20);
    let html = ws.read("results/model_updating/report/report/index.html");
    assert!(html.contains("Accuracy per position"), "per-position table");
    assert!(html.contains("<script>"), "zoom of dense figures");
}

/// Frequencies of the reference modes paired in an evaluate stage's
/// pairs.csv: (reference Hz, candidate Hz, MAC) per pair.
fn paired(ws: &util::Workspace, stage: &str) -> Vec<(f64, f64, f64)> {
    let rows = csv_rows(&ws.read(&format!("results/real_beam/{stage}/tables/pairs.csv")));
    rows.iter()
        .skip(1)
        .map(|r| {
            (
                r[3].parse().unwrap(),
                r[4].parse().unwrap(),
                r[9].parse().unwrap(),
            )
        })
        .collect()
}

/// The pair of the measured mode within 3 % of `hz` that pairs best
/// (highest MAC), if any: the mode of that shape. The shaker test holds a
/// second mode 2 Hz above its B4 (264.3 and 266.2 Hz), no bending mode;
/// the nearest in frequency picked it once its rounding (autoema 17) let it
/// pair weakly with a model mode 9.5 % away (MAC 0.65).
fn near(pairs: &[(f64, f64, f64)], hz: f64) -> Option<(f64, f64, f64)> {
    pairs
        .iter()
        .copied()
        .filter(|p| (p.0 - hz).abs() <= 0.03 * hz)
        .max_by(|a, b| a.2.total_cmp(&b.2))
}

/// The real beam (docs/studies/real_beam.md): updated on the roving-hammer
/// test, the model (a beam on elastic ends that share one bouncing support
/// frame) predicts the shaker test it never saw. CI size: a small screening
/// and the guided update on 5/8 of the budget, no black box.
#[test]
fn real_beam_updated_on_the_hammer_predicts_the_shaker() {
    let Some(dir) = util::real_beam_dir() else {
        return;
    };
    let read_outside = format!("read_outside: [{}]", dir.display());
    let ws = study(
        "real_beam",
        &[
            (
                "read_outside: [../../shared/data/real/beam_ufsc_ss]",
                &read_outside,
            ),
            ("path: ../../shared/data/real/beam_ufsc_ss/", "path: data/"),
            ("samples: 64", "samples: 16"),
            ("bootstrap: 50", "bootstrap: 10"),
            (
                "strategy: sensitivity_guided\n      budget: 8000",
                "strategy: sensitivity_guided\n      budget: 5000",
            ),
            (
                "[guided, guided_frf, pso, ga, guided_on_shaker]",
                "[guided]",
            ),
        ],
    );
    std::os::unix::fs::symlink(&dir, ws.path().join("data")).unwrap();
    ws.run(&["on_hammer", "on_shaker", "initial_on_hammer"], 0);
    let hammer = paired(&ws, "on_hammer[run=guided]");
    let shaker = paired(&ws, "on_shaker[run=guided]");
    let initial = paired(&ws, "initial_on_hammer");
    let e = |p: (f64, f64, f64)| (p.1 / p.0 - 1.0).abs();
    // Bending modes 1-6: within 1.5 % of the test fitted to (the full
    // study: +0.48, -1.12, -0.33, +0.36, -1.19, +0.69 %), MAC >= 0.9 (B6:
    // 0.85, its shape carries the torsion these tests leave open: G ends at
    // a bound, docs), and no farther than the model at its file values. On
    // the test never seen: modes 3-5 within 2 %, MAC >= 0.85 (B6 0.7, the
    // same reason); modes 1 and 2, which the shaker test itself puts 2.8 %
    // and 2.1 % above the hammer test (docs: no attachment at the drive
    // point explains that), within 3.5 %; the shaker's mode 1 shape (two
    // lines in its half-power band, Hanning) at MAC >= 0.7.
    for (hz, seen_mac, unseen, unseen_mac) in [
        (17.35, 0.9, 0.035, 0.7),
        (69.2, 0.9, 0.035, 0.85),
        (155.6, 0.9, 0.02, 0.85),
        (265.6, 0.9, 0.02, 0.85),
        (414.5, 0.9, 0.02, 0.85),
        (567.6, 0.85, 0.02, 0.7),
    ] {
        let h = near(&hammer, hz).unwrap_or_else(|| panic!("{hz} Hz unpaired: {hammer:?}"));
        let s = near(&shaker, hz).unwrap_or_else(|| panic!("{hz} Hz unpaired: {shaker:?}"));
        assert!(e(h) < 0.015 && h.2 >= seen_mac, "hammer {hz}: {h:?}");
        assert!(e(s) < unseen && s.2 >= unseen_mac, "shaker {hz}: {s:?}");
        if let Some(i) = near(&initial, hz) {
            assert!(e(h) <= e(i) + 0.005, "{hz}: updated {h:?} vs initial {i:?}");
        }
    }
    // The support frame's bounce is the measured 118.6 Hz mode whose ends
    // move (within 1 %; its shape only partly: MAC about 0.6).
    let bounce = near(&hammer, 118.6).expect("the 118.6 Hz mode paired");
    assert!(e(bounce) < 0.01 && bounce.2 >= 0.5, "{bounce:?}");
    // E plausible for steel (the bending modes fix E h²), with its interval.
    let params = csv_rows(&ws.read("results/real_beam/guided/parameters.csv"));
    let e = params.iter().find(|r| r[0] == "beam.E").unwrap();
    let (value, low, high): (f64, f64, f64) = (
        e[1].parse().unwrap(),
        e[9].parse().unwrap(),
        e[10].parse().unwrap(),
    );
    // Full study: 187.1 GPa, 95 % interval 177.9-196.9 GPa.
    assert!((1.75e11..2.15e11).contains(&value), "{e:?}");
    assert!(
        low < value && value < high && low > 1.6e11 && high < 2.2e11,
        "{e:?}"
    );
    // What the model cannot explain is named, not absorbed: the verdict
    // lists the measured modes left without a model partner.
    let cost: Value = ws.json("results/real_beam/guided/cost.json");
    assert!(
        cost["verdict"]["modes"]["unpaired"].as_u64().unwrap() >= 3,
        "{cost}"
    );
    // One model file per test set-up: the shaker's differs from the
    // hammer's only in its header and its attachments (`masses:`), so the
    // values identified on one test mean the same on the other.
    let model = ws.read("models/ufsc_beam.yaml");
    let body = |text: &str| -> String {
        let from = text.find("\nparameters:").expect("parameters");
        let to = text.find("\n# Lumped masses").expect("masses");
        let after = text[to..].find("\nsensors:").expect("sensors") + to;
        format!("{}{}", &text[from..to], &text[after..])
    };
    assert_eq!(
        body(&model),
        body(&ws.read("models/ufsc_beam_shaker.yaml")),
        "the two set-ups' model files differ beyond their attachments"
    );
    // Editing one support bound reruns the screening and the updates, not
    // the imports, the AutoEMA or the model-free stages.
    let edited = model.replacen(
        "{name: left.k_z, value: 1.0e+07, lower: 1.0e+05, upper: 1.0e+09,",
        "{name: left.k_z, value: 1.0e+07, lower: 1.0e+05, upper: 2.0e+09,",
        1,
    );
    assert_ne!(edited, model, "left.k_z bound not found");
    ws.write("models/ufsc_beam.yaml", &edited);
    let status = ws.status();
    for (name, cached) in [
        ("hammer", true),
        ("ema_hammer", true),
        ("ema_shaker", true),
        ("gsa", false),
        ("guided", false),
        ("nominal_shaker", true),
    ] {
        let s = status.stage(name)["status"]
            .as_str()
            .unwrap_or_default()
            .to_string();
        assert_eq!(s == "cached", cached, "{name}: {s}");
    }
}

/// The new user's study (issue 29) in one file: the measurement goes out
/// as UFF and comes back in by path, then AutoEMA, GSA, the guided update
/// with FRFs, the evaluation and the report — CI-sized.
#[test]
fn new_user_study_runs_as_one_pipeline() {
    let ws = study(
        "new_user_study",
        &[
            ("samples: 64", "samples: 8"),
            ("bootstrap: 50", "bootstrap: 5"),
            ("budget: 8000", "budget: 2000"),
            (
                "params: {band: [10, 200]}",
                "params: {band: [10, 200], iterations: 8, initial: 4}",
            ),
        ],
    );
    // The import needs only the export: it runs before the file exists.
    let r = ws.run(&["measured"], 0);
    assert_eq!(r.status_of("measured"), "ran");
    assert!(ws.path().join("data/new_user_study/frf.uff").is_file());
    let r = ws.run(&[], 0);
    assert!(
        r.statuses()
            .iter()
            .all(|(_, s)| s == "ran" || s == "cached"),
        "{:?}",
        r.statuses()
    );
    let metrics = ws.read("results/new_user_study/score/metrics.json");
    assert!(metrics.contains("frac"), "{metrics}");
    assert!(ws
        .path()
        .join("results/new_user_study/report/report/index.html")
        .is_file());
}

/// The measured bridge (pipelines/real_bridge.yaml, data in
/// benchmarks/real_sets/cermelj_dam0): the six literature modes within
/// 1 %, none left over, the two layouts the same modes (MAC > 0.99), and
/// the report's figures (stabilization, MAC, shapes on the girders).
#[test]
fn real_bridge_finds_its_modes_in_both_layouts() {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/benchmarks/real_sets/cermelj_dam0"
    );
    let ws = study(
        "real_bridge",
        &[
            (
                "read_outside: [../benchmarks/real_sets/cermelj_dam0]",
                &format!("read_outside: [{dir}]"),
            ),
            ("../benchmarks/real_sets/cermelj_dam0/", "data/"),
        ],
    );
    std::os::unix::fs::symlink(dir, ws.path().join("data")).unwrap();
    ws.run(&[], 0);
    let m: Value = ws.json("results/real_bridge/against_literature/metrics.json");
    let pos = &m["modes"]["positions"][0];
    assert_eq!(pos["paired"], 6, "{m}");
    assert_eq!(pos["unpaired_reference"].as_array().map(Vec::len), Some(0));
    assert_eq!(pos["unpaired_candidate"].as_array().map(Vec::len), Some(0));
    assert!(pos["max_nfd"].as_f64().unwrap() < 0.01, "{m}");
    let m: Value = ws.json("results/real_bridge/layouts/metrics.json");
    assert_eq!(m["modes"]["paired"], 6, "{m}");
    assert!(
        m["modes"]["positions"][0]["min_mac"].as_f64().unwrap() > 0.99,
        "{m}"
    );
    assert!(util::assert_report_figures(&ws, "real_bridge") >= 3);
}
