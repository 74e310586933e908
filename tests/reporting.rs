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
    let m: Metrics = ws.json("results/verdicts/check/metrics.json");
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
    assert!(first_div < html.find("<h2").unwrap(), "the box comes first");
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
        let id: Value = ws.json(&format!("results/verdicts/{stage}/identifiability.json"));
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

/// A CI-sized study with everything a reviewer asks for (issue 29): an
/// initial model (`nominal`, the file values) and an update of it, both
/// evaluated against the truth's modes and FRFs, and a stage summary
/// with warnings (a command writes one, with a raw float).
const EVIDENCE: &str = r#"name: evidence
stages:
  truth:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, values: {k1.k_x: 2.4e6, k12.k_x: 1.3e6, k23.k_x: 1.15e6, k3.k_x: 4.2e5}}
  nominal:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}
  fit:
    kind: identify
    inputs: {model: nominal.model, reference: truth.modes}
    params: {strategy: black_box, optimizer: slsqp, budget: 3000, window: 0.3}
  updated:
    kind: synthesize
    inputs: {values: fit.parameters}
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}}
  notes:
    kind: command
    params: {cmd: "printf '{\"warnings\": [\"position 0: mode at 45.1 Hz missed (98x the noise)\", \"position 2: mode at 51.25 Hz missed (12x the noise)\", \"k = 1.5000000000000005e6 at its bound\"]}' > summary", outs: [summary]}
  initial:
    kind: evaluate
    inputs: {reference: truth.modes, candidate: nominal.modes, reference_frf: truth.frf, candidate_frf: nominal.frf, truth: truth.truth, estimate: nominal.truth, geometry: truth.model}
    params: {vertical: x}
  score:
    kind: evaluate
    inputs: {reference: truth.modes, candidate: updated.modes, reference_frf: truth.frf, candidate_frf: updated.frf, initial_frf: nominal.frf, truth: truth.truth, estimate: fit.parameters, cost: fit.cost, geometry: truth.model}
  report:
    kind: report
    inputs:
      metrics: [score.metrics]
      tables: [score.tables]
      initial: initial.metrics
      initial_tables: initial.tables
      costs: [fit.cost]
      histories: [fit.history]
      parameters: [fit.parameters]
      warnings: [notes.summary]
      figures: [score.plots]
"#;

/// A markdown table row's cells after the first, by its first cell.
fn row<'a>(md: &'a str, first: &str) -> Vec<&'a str> {
    md.lines()
        .find(|l| l.starts_with(&format!("| {first} |")))
        .unwrap_or_else(|| panic!("no row {first:?} in\n{md}"))
        .trim_matches('|')
        .split(" | ")
        .skip(1)
        .map(str::trim)
        .collect()
}

#[test]
fn report_leads_with_the_evidence_a_reviewer_asks_for() {
    let ws = setup();
    ws.write("p.yaml", EVIDENCE);
    // The model file states its vertical axis (evaluate's `vertical`
    // param, where given, overrides it).
    let model = ws.read("three_mass.yaml");
    ws.write("three_mass.yaml", &format!("{model}\nvertical: z\n"));
    let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
    let stdout = util::text(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        util::text(&out.stderr)
    );
    // The command line ends with the count of the warnings the report
    // lists: the command's 3 and the identification's own.
    let fit_warnings = ws.cost("results/evidence/fit").verdict.warnings.len();
    let total = 3 + fit_warnings;
    assert!(
        stdout.contains(&format!(
            "report: {total} warning(s) of the stages upstream"
        )),
        "{stdout}"
    );
    let dir = "results/evidence/report/report";
    let md = ws.read(&format!("{dir}/report.md"));
    let html = ws.read(&format!("{dir}/index.html"));

    // 1. Initial vs updated, before the accuracy details: the update
    // raises FRAC and MAC over the initial model's.
    let evidence = md.find("## Initial vs updated model").expect("section");
    assert!(evidence < md.find("## Accuracy").unwrap(), "{md}");
    let num = |c: &str| c.parse::<f64>().unwrap_or_else(|_| panic!("{c:?}"));
    for criterion in ["mean FRAC", "mean MAC"] {
        let r = row(&md, criterion);
        assert!(num(r[0]) < num(r[1]), "{criterion}: {r:?}");
    }
    let per_mode = row(&md, "0");
    assert_eq!(per_mode.len(), 2 + 2 * 2, "{per_mode:?}");
    assert!(md.contains("](figures/initial_vs_updated.svg)"), "{md}");

    // 2. Warnings collapsed and counted: two differ only in numbers.
    let stages = 1 + usize::from(fit_warnings > 0);
    assert!(
        md.contains(&format!("**⚠ {total} warning(s) from {stages} stage(s)")),
        "{md}"
    );
    assert_eq!(row(&md, "notes")[0], "2×", "{md}");

    // 3. The truth beside the identified parameters.
    let header = md
        .lines()
        .find(|l| l.starts_with("| parameter | value | start |"))
        .expect("parameter table");
    assert!(
        header.contains("| truth | error % | truth in interval |"),
        "{header}"
    );
    assert!(row(&md, "k12.k_x")[5].starts_with("1.3e6"), "{md}");

    // 8. No raw float anywhere in the page.
    assert!(
        !html.contains("1.5000000000000005e6"),
        "raw float in the page"
    );
    assert!(md.contains("k = 1.5e6 at its bound"), "{md}");

    // 4. Every FRF channel: one panel per row of frac.csv, and no two
    // figures share a title.
    let channels = ws
        .read("results/evidence/score/tables/frac.csv")
        .lines()
        .skip(1)
        .filter(|l| l.starts_with("0,"))
        .count();
    let grid = ws.read(&format!("{dir}/figures/score_plots_frf_channels_0.svg"));
    assert_eq!(grid.matches("· FRAC ").count(), channels, "{grid}");
    // 7. Views named from the vertical axis: the model file's, unless the
    // param says otherwise.
    let shapes = ws.read(&format!("{dir}/figures/score_plots_shapes_0.svg"));
    assert!(shapes.contains(">top x–y (down z)<"), "{shapes}");
    let initial = ws.read("results/evidence/initial/plots/shapes_0.svg");
    assert!(initial.contains(" (x up)<"), "{initial}");
    assert!(!initial.contains("(down z)"), "{initial}");
    let mut titles = Vec::new();
    let mut problems = Vec::new();
    for entry in std::fs::read_dir(ws.path().join(format!("{dir}/figures"))).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "svg") {
            continue;
        }
        let svg = std::fs::read_to_string(&path).unwrap();
        let title = svg
            .split("font-weight=\"bold\">")
            .nth(1)
            .unwrap_or_default();
        titles.push(title.split('<').next().unwrap_or_default().to_string());
        // 9. At the page's width: readable fonts, no overlapping labels.
        problems.extend(
            modalflow::report::lint::check_rendered(&svg, modalflow::report::lint::PAGE_WIDTH)
                .into_iter()
                .map(|p| format!("{}: {p}", path.display())),
        );
    }
    let n = titles.len();
    titles.sort();
    titles.dedup();
    assert_eq!(titles.len(), n, "figure titles repeat: {titles:?}");
    assert!(problems.is_empty(), "{problems:#?}");
    util::assert_report_figures(&ws, "evidence");
}

/// Issue 29: the report lists the warnings of every stage upstream of it —
/// here a synthesize stage's (an impact test whose lines miss the grid's
/// step) and AutoEMA's, neither bound to the report — and `run` ends with
/// the same count whether the stages ran or were cached.
const UPSTREAM: &str = r#"name: upstream
stages:
  truth:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.25}}
  hammer:
    kind: synthesize
    params: {model: three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, impact_test: {averages: 2, response_noise: 0.002}}
  ema:
    kind: autoema
    inputs: {frf: hammer.frf}
    # a stability tolerance too tight for the data: modes the data show
    # are missed, each a warning
    params: {max_order: [6, 24], iterations: 20, initial: 8, bounds: {frequency_tol: [0.00001, 0.00002]}}
  score:
    kind: evaluate
    inputs: {reference: truth.modes, candidate: ema.modes}
    params: {window: 0.1, min_mac: 0.5}
  report:
    kind: report
    inputs: {metrics: [score.metrics]}
"#;

#[test]
fn the_report_and_the_run_count_every_upstream_stage_s_warnings() {
    let ws = setup();
    ws.write("p.yaml", UPSTREAM);
    let human = |ws: &Workspace| {
        let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
        assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
        util::text(&out.stdout)
    };
    let ran = human(&ws);
    let report = ws.run(&[], 0);
    let warnings = |s: &str| -> Vec<String> {
        assert_eq!(report.status_of(s), "cached");
        serde_json::from_value(report.stage(s)["warnings"].clone()).unwrap_or_default()
    };
    let hammer = warnings("hammer");
    assert!(
        hammer
            .iter()
            .any(|w| w.starts_with("impact_test: the FRF lines")),
        "{hammer:?}"
    );
    // AutoEMA's warnings (metrics.json) are its stage warnings, cached too.
    let ema = warnings("ema");
    let metrics: Value = ws.json("results/upstream/ema/metrics.json");
    let in_metrics: Vec<String> = serde_json::from_value(metrics["warnings"].clone()).unwrap();
    assert!(!ema.is_empty(), "{metrics}");
    assert_eq!(ema, in_metrics);

    // The report names both stages and counts every upstream warning.
    let upstream = ["truth", "hammer", "ema", "score"];
    let total: usize = upstream.iter().map(|s| warnings(s).len()).sum();
    let stages = upstream.iter().filter(|s| !warnings(s).is_empty()).count();
    let md = ws.read("results/upstream/report/report/report.md");
    assert!(
        md.contains(&format!("**⚠ {total} warning(s) from {stages} stage(s)")),
        "{md}"
    );
    assert!(
        row(&md, "hammer")[1].starts_with("impact_test: the FRF lines"),
        "{md}"
    );
    // AutoEMA's missed modes differ only in their numbers: one row.
    assert_eq!(row(&md, "ema")[0], format!("{}×", ema.len()), "{md}");

    // `run` ends with the same counts, ran or cached, and says where.
    let cached = human(&ws);
    for text in [&ran, &cached] {
        let tail: Vec<&str> = text.lines().filter(|l| l.contains("warning(s)")).collect();
        assert!(
            tail[0].starts_with(&format!("{total} stage warning(s): ")),
            "{text}"
        );
        assert!(tail[0].contains(&format!("ema {}", ema.len())), "{text}");
        assert!(
            tail[1].starts_with(&format!(
                "report: {total} warning(s) of the stages upstream"
            )),
            "{text}"
        );
        assert!(
            tail[1].ends_with("report/report/index.html#warnings"),
            "{text}"
        );
    }
    assert_eq!(
        ran.lines()
            .filter(|l| l.contains("warning(s)"))
            .collect::<Vec<_>>(),
        cached
            .lines()
            .filter(|l| l.contains("warning(s)"))
            .collect::<Vec<_>>()
    );
}
