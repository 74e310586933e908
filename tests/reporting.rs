//! Results that cannot be misread: identifications whose verdict fails (a
//! budget too small to converge, a reference from a different model) are
//! marked ✗ with their message at the top of the report (HTML and
//! Markdown), in its cost table and in `modalflow compare`, beside one that
//! passes; `evaluate` copies the verdict it is given; the report shows the
//! parameter combinations the data do not determine, the identified
//! parameters with their uncertainty and the mode correlation.

use crate::util;

use modalflow::artifacts::cost::Cost;
use modalflow::artifacts::metrics::Metrics;
use modalflow::identify::verdict::Fit;
use modalflow::report::svg::esc;
use serde_json::Value;
use util::Workspace;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines/models");

const PIPELINE: &str = r#"name: verdicts
stages:
  truth:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, values: {k1.k_x: 2.4e6, k12.k_x: 1.3e6, k23.k_x: 1.15e6, k3.k_x: 4.2e5}}
  other:
    kind: synthesize
    params: {model: heavier.yaml, frequency: {min: 0, max: 400, step: 0.5}}
  good:
    kind: identify
    inputs: {model: truth.model, reference: truth.modes}
    params: {strategy: black_box, optimizer: slsqp, budget: 3000, window: 0.3}
  starved:
    kind: identify
    inputs: {model: truth.model, reference: truth.modes}
    params: {strategy: black_box, optimizer: slsqp, budget: 60, window: 0.3}
  mismatch:
    kind: identify
    inputs: {model: truth.model, reference: other.modes}
    params: {strategy: black_box, optimizer: slsqp, budget: 3000, window: 0.3}
  check:
    kind: evaluate
    inputs: {reference: other.modes, candidate: mismatch.updated_modes, cost: mismatch.cost}
  report:
    kind: report
    inputs:
      costs: [good.cost, starved.cost, mismatch.cost]
      metrics: [check.metrics]
      identifiability: [good.identifiability, mismatch.identifiability]
      parameters: [good.parameters, mismatch.parameters]
      correlation: [good.correlation]
"#;

fn setup() -> Workspace {
    let ws = Workspace::new();
    let model = std::fs::read_to_string(format!("{MODELS}/three_mass.yaml")).unwrap();
    ws.write("three_mass.yaml", &model);
    // A different machine: the middle mass 60 % heavier, which no stiffness
    // of the three-mass model reproduces.
    assert!(model.contains("mass: 1.0,"));
    ws.write("heavier.yaml", &model.replace("mass: 1.0,", "mass: 1.6,"));
    ws.write("p.yaml", PIPELINE);
    ws
}

fn cost(ws: &Workspace, stage: &str) -> Cost {
    ws.cost(&format!("results/verdicts/{stage}"))
}

#[test]
fn failed_verdicts_are_prominent_in_report_and_compare() {
    let ws = setup();
    ws.run(&[], 0);
    let good = cost(&ws, "good");
    assert!(good.verdict.ok, "{:?}", good.verdict);
    let failed = [cost(&ws, "starved"), cost(&ws, "mismatch")];
    for c in &failed {
        assert!(!c.verdict.ok, "{:?}", c.verdict);
    }

    // evaluate copies the verdict unchanged.
    let m: Metrics = serde_json::from_str(&ws.read("results/verdicts/check/metrics.json")).unwrap();
    assert_eq!(m.verdict.as_ref(), Some(&failed[1].verdict));

    let md = ws.read("results/verdicts/report/report/report.md");
    let html = ws.read("results/verdicts/report/report/index.html");
    // First thing on the page: the failure box with each failed message.
    let first_block = md.split("\n\n").nth(1).unwrap();
    assert!(
        first_block.starts_with("> **✗ 2 of 3 identifications FAILED the verdict"),
        "{md}"
    );
    let first_div = html
        .find("<div class=\"callout failure\">")
        .expect("failure box");
    assert!(
        first_div < html.find("<h2>").unwrap(),
        "the box comes first"
    );
    for (stage, c) in ["starved", "mismatch"].iter().zip(&failed) {
        assert!(
            first_block.contains(&format!("> - {stage}: {}", c.verdict.message)),
            "{md}"
        );
        assert!(html.contains(&format!("<li>{stage}: {}</li>", esc(&c.verdict.message))));
        let row = md
            .lines()
            .find(|l| l.starts_with(&format!("| {stage} | black_box / slsqp |")))
            .unwrap_or_else(|| panic!("no cost row for {stage} in\n{md}"));
        assert!(row.contains("| **✗ failed** |"), "{row}");
        assert!(row.contains(&c.verdict.message), "{row}");
        if c.verdict.fit == Fit::AboveNoise {
            let fit = format!("✗ above noise ({:.2}σ", c.verdict.end_rms);
            assert!(row.contains(&fit), "{row}");
        }
    }
    assert!(
        md.lines()
            .any(|l| l.starts_with("| good |") && l.contains("| ✓ ok |")),
        "{md}"
    );
    assert!(
        md.lines()
            .any(|l| l.starts_with("| check |") && l.ends_with("| **✗ failed** |")),
        "{md}"
    );
    assert_eq!(
        html.matches("<td class=\"fail\">✗ failed</td>").count(),
        3,
        "2 costs + 1 accuracy row"
    );

    // Identifiability: the undetermined combinations of each stage, and the
    // identified parameters with value, error and interval.
    assert!(md.contains("## Identifiability and uncertainty"), "{md}");
    for stage in ["good", "mismatch"] {
        let id: Value = serde_json::from_str(
            &ws.read(&format!("results/verdicts/{stage}/identifiability.json")),
        )
        .unwrap();
        let section = md.split(&format!("### {stage}\n")).nth(1).unwrap();
        let section = section.split("\n#").next().unwrap();
        for line in id["undetermined_text"].as_array().unwrap() {
            assert!(
                section.contains(&format!("> - {}", line.as_str().unwrap())),
                "{section}"
            );
        }
        assert!(section.contains(
            "| parameter | value | start | std error % | 95 % interval | identifiable |"
        ));
        let params = ws.read(&format!("results/verdicts/{stage}/parameters.csv"));
        let k1 = util::csv_row(&params, "k1.k_x");
        let row = section
            .lines()
            .find(|l| l.starts_with("| k1.k_x |"))
            .unwrap();
        if k1[6] == "true" {
            assert!(row.ends_with("| ✓ yes |") && row.contains(" ["), "{row}");
        } else {
            assert!(row.contains("**✗ no"), "{row}");
        }
    }
    // Correlation: every reference mode with its partners.
    let corr = md
        .split("## Mode correlation")
        .nth(1)
        .expect("correlation section");
    // … and the σ its residuals were scaled by (between used and partner).
    let used = corr
        .lines()
        .filter(|l| l.contains("| yes | ") && l.contains(" % / ") && l.contains("| p0.mode"))
        .count();
    assert_eq!(used, 3, "{corr}");

    // compare: the verdict's text and boolean leaves are columns.
    let out = ws.cmd(&["compare", "p.yaml", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    let table: Value = serde_json::from_slice(&out.stdout).unwrap();
    let row = |stage: &str| -> Value {
        table["rows"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["stage"] == stage)
            .unwrap_or_else(|| panic!("no row {stage}: {table}"))["metrics"]
            .clone()
    };
    assert_eq!(row("good")["verdict.ok"], true);
    assert_eq!(row("good")["verdict.status"], "converged");
    assert_eq!(row("good")["verdict.fit"], "within_noise");
    for (stage, c) in ["starved", "mismatch", "check"]
        .iter()
        .zip([&failed[0], &failed[1], &failed[1]])
    {
        let r = row(stage);
        assert_eq!(r["verdict.ok"], false, "{stage}: {r}");
        assert_eq!(
            r["verdict.status"],
            serde_json::to_value(c.verdict.status).unwrap()
        );
        assert_eq!(
            r["verdict.fit"],
            serde_json::to_value(c.verdict.fit).unwrap()
        );
        assert_eq!(r["verdict.end_rms"].as_f64(), Some(c.verdict.end_rms));
        assert_eq!(r["verdict.message"], c.verdict.message.as_str());
    }
    // The verdict columns come first; the human table lists failed messages.
    let good = row("good");
    let first: Vec<&String> = good.as_object().unwrap().keys().take(4).collect();
    assert_eq!(
        first,
        [
            "verdict.ok",
            "verdict.status",
            "verdict.fit",
            "verdict.end_rms"
        ]
    );
    let human = util::text(&ws.cmd(&["compare", "p.yaml"]).stdout);
    assert!(
        human.contains(&format!("✗ starved: {}", failed[0].verdict.message)),
        "{human}"
    );
    assert!(!human.contains("✗ good"), "{human}");
}
