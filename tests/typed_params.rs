//! Typed stage params (issue 15): every problem of a file in one round,
//! value ranges and artifact types checked at validation, and the `kinds`
//! listing read from the params structs. One module per topic.

use crate::util;

use util::Workspace;

const THREE_MASS: &str = include_str!("../pipelines/models/three_mass.yaml");

/// A workspace with `p.yaml` = `yaml` and the three-mass model.
fn workspace(yaml: &str) -> Workspace {
    let ws = Workspace::new();
    ws.write("p.yaml", yaml);
    ws.write("models/three_mass.yaml", THREE_MASS);
    ws
}

/// `modalflow validate p.yaml`: exit code and stderr.
fn validate(ws: &Workspace) -> (Option<i32>, String) {
    let out = ws.cmd(&["validate", "p.yaml"]);
    (out.status.code(), util::text(&out.stderr))
}

/// Numbered problems (`[k] …`) in a diagnostics text.
fn problems(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with('[')).collect()
}

/// A synthesize stage `truth` with `extra` params added.
fn truth(extra: &str) -> String {
    format!(
        "name: t\nstages:\n  truth:\n    kind: synthesize\n    params: {{model: models/three_mass.yaml, frequency: {{min: 0, max: 100, step: 1}}{extra}}}\n"
    )
}

/// A sobol gsa stage on the Ishigami function with `extra` params added.
fn ishigami(extra: &str) -> String {
    format!(
        "name: g\nstages:\n  sens:\n    kind: gsa\n    params: {{model: {{builtin: ishigami}}{extra}}}\n"
    )
}

mod one_round {
    use super::*;

    /// Problems in four stages (unknown, range, type, missing, nested,
    /// unknown kind, wrong artifact) all come in one validation.
    #[test]
    fn every_problem_of_every_stage() {
        let ws = workspace(
            r#"name: bad
stages:
  truth:
    kind: synthesize
    params:
      model: models/three_mass.yaml
      frequency: {min: 0, max: 400, step: 0.25}
      impact_test: {averages: 0}
      nosie: {relative: 0.01}
  ema:
    kind: autoema
    inputs: {frf: truth.modes}
    params: {iterations: 0, initial: many}
  sens:
    kind: gsa
    params: {model: {builtin: ishigami}, samples: 1, bootstrap: 0, threshold: 2}
  cmd:
    kind: command
    params: {deps: []}
  typo:
    kind: evalute
    inputs: {reference: truth.modes}
  after:
    kind: evaluate
    inputs: {reference: typo.modes, candidate: ema.modes}
"#,
        );
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(2), "{stderr}");
        let expected = [
            "unknown param `nosie` for stage `truth` (kind `synthesize`)",
            "impact_test `averages` = 0 is out of range",
            "param `iterations` = 0 is out of range",
            "param `initial` of stage `ema` must be an integer",
            "param `samples` = 1 is out of range [2,",
            "param `bootstrap` = 0 is out of range [1,",
            "`threshold` must lie strictly between 0 and 1",
            "stage `cmd` (kind `command`) needs param `cmd`",
            "unknown stage kind `evalute` in stage `typo`",
            "input `frf` of stage `ema` takes a `frf` artifact, but `truth.modes` is a `modes` artifact",
        ];
        for e in expected {
            assert!(stderr.contains(e), "missing {e:?} in:\n{stderr}");
        }
        // Nothing more: the reference to the unknown-kind stage is not
        // reported again.
        assert_eq!(problems(&stderr).len(), expected.len(), "{stderr}");
        assert!(stderr.contains("10 problems in pipeline file"), "{stderr}");
    }

    /// Each problem points at its place: the key of an unknown param, the
    /// value of a bad one, the nested field of a settings mapping.
    #[test]
    fn problems_are_located() {
        let ws = workspace(&truth(", impact_test: {averages: 0}, noise_level: 2"));
        let (_, stderr) = validate(&ws);
        let line = "    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, impact_test: {averages: 0}, noise_level: 2}";
        let col = |needle: &str| line.find(needle).unwrap() + 1;
        assert!(
            stderr.contains(&format!("p.yaml:5:{}", col("noise_level"))),
            "{stderr}"
        );
        assert!(
            stderr.contains(&format!("p.yaml:5:{}", col("0}, noise"))),
            "{stderr}"
        );
    }

    /// A nested unknown key is named by its path below `params`.
    #[test]
    fn nested_unknown_key_has_its_path() {
        let ws = workspace(&truth(", impact_test: {avrages: 3}"));
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(2));
        assert!(
            stderr.contains("param `impact_test.avrages` of stage `truth`"),
            "{stderr}"
        );
    }
}

mod ranges {
    use super::*;

    fn rejected(yaml: &str, needle: &str) {
        let ws = workspace(yaml);
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(2), "{yaml}\n{stderr}");
        assert!(stderr.contains(needle), "missing {needle:?} in:\n{stderr}");
        assert_eq!(problems(&stderr).len(), 1, "{stderr}");
    }

    fn accepted(yaml: &str) {
        let ws = workspace(yaml);
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(0), "{yaml}\n{stderr}");
    }

    #[test]
    fn sample_counts() {
        rejected(&ishigami(", samples: 1"), "`samples` = 1 is out of range");
        rejected(&ishigami(", samples: 1000000000"), "`samples` = 1000000000");
        accepted(&ishigami(", samples: 2"));
    }

    #[test]
    fn bootstrap_at_least_one_or_absent() {
        rejected(
            &ishigami(", bootstrap: 0"),
            "`bootstrap` = 0 is out of range",
        );
        accepted(&ishigami(", bootstrap: 1"));
        accepted(&ishigami(""));
    }

    #[test]
    fn thresholds_strictly_inside_zero_one() {
        for t in ["0", "1", "2", "-0.1"] {
            rejected(
                &ishigami(&format!(", threshold: {t}")),
                "`threshold` must lie strictly between 0 and 1",
            );
        }
        accepted(&ishigami(", threshold: 0.5"));
        rejected(
            &ishigami(", confidence: 1"),
            "`confidence` must lie strictly",
        );
    }

    #[test]
    fn resource_sized_values_are_bounded() {
        rejected(
            &truth(", impact_test: {block_size: 100000000}"),
            "impact_test `block_size` = 100000000 is out of range",
        );
        rejected(
            &truth(", impact_test: {averages: 1000000}"),
            "impact_test `averages` = 1000000 is out of range",
        );
        rejected(
            "name: a\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}}\n  ema:\n    kind: autoema\n    inputs: {frf: truth.frf}\n    params: {iterations: 100000000}\n",
            "`iterations` = 100000000 is out of range",
        );
        accepted(&truth(", impact_test: {averages: 3}"));
        let ident = "name: i\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}}\n  id:\n    kind: identify\n    inputs: {model: truth.model, reference: truth.modes}\n    params: {budget: BUDGET}\n";
        rejected(
            &ident.replace("BUDGET", "0"),
            "`budget` must be an integer in [1,",
        );
        rejected(
            &ident.replace("BUDGET", "1000000000"),
            "`budget` must be an integer in [1,",
        );
        accepted(&ident.replace("BUDGET", "500"));
    }

    #[test]
    fn gsa_band_count_is_bounded() {
        let model = "name: g\nstages:\n  sens:\n    kind: gsa\n    params: {model: models/three_mass.yaml, modes: 3, samples: 8, bands: BANDS}\n";
        rejected(
            &model.replace("BANDS", "{min: 0, max: 100, count: 5000}"),
            "`count` must be a whole number of bands in 1..=1000",
        );
        accepted(&model.replace("BANDS", "{min: 0, max: 100, count: 4}"));
    }

    #[test]
    fn zero_jobs_is_rejected() {
        let ws = workspace(&ishigami(""));
        let out = ws.cmd(&["run", "p.yaml", "--jobs", "0"]);
        assert_eq!(out.status.code(), Some(2), "{}", util::text(&out.stderr));
        assert!(util::text(&out.stderr).contains("--jobs"));
        assert!(!ws.path().join("cache/runs").exists());
    }
}

mod artifact_types {
    use super::*;

    /// A `modes` artifact bound to an `frf` input is a validation error
    /// naming both types and the output that fits; nothing runs.
    #[test]
    fn modes_into_frf_is_a_validation_error() {
        let ws = workspace(
            "name: a\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}}\n  ema:\n    kind: autoema\n    inputs: {frf: truth.modes}\n",
        );
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(2), "{stderr}");
        assert!(
            stderr.contains("input `frf` of stage `ema` takes a `frf` artifact, but `truth.modes` is a `modes` artifact"),
            "{stderr}"
        );
        assert!(stderr.contains("did you mean truth.frf?"), "{stderr}");
        assert!(stderr.contains("p.yaml:8:19"), "{stderr}");
        let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
        assert_eq!(out.status.code(), Some(2));
        assert!(!util::text(&out.stderr).contains("Is a directory"));
        assert!(!ws.path().join("cache/runs").exists());
    }

    /// Table-like artifacts fit a table input; an `frf` does not fit a
    /// `modes` input of evaluate.
    #[test]
    fn frf_into_modes_is_a_validation_error() {
        let ws = workspace(
            "name: a\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}}\n  score:\n    kind: evaluate\n    inputs: {reference: truth.frf, candidate: truth.modes}\n",
        );
        let (code, stderr) = validate(&ws);
        assert_eq!(code, Some(2), "{stderr}");
        assert!(
            stderr.contains("input `reference` of stage `score` takes a `modes` artifact, but `truth.frf` is a `frf` artifact"),
            "{stderr}"
        );
        assert_eq!(problems(&stderr).len(), 1, "{stderr}");
    }
}

mod kinds_listing {
    use super::*;
    use serde_json::Value;

    fn kinds_json() -> Value {
        let ws = Workspace::new();
        let out = ws.cmd(&["kinds", "--json"]);
        assert_eq!(out.status.code(), Some(0));
        serde_json::from_slice(&out.stdout).unwrap()
    }

    fn kind<'a>(all: &'a Value, name: &str) -> &'a Value {
        all["kinds"]
            .as_array()
            .unwrap()
            .iter()
            .find(|k| k["kind"] == name)
            .unwrap_or_else(|| panic!("no kind {name}"))
    }

    fn param<'a>(k: &'a Value, name: &str) -> &'a Value {
        k["params"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("no param {name} in {k}"))
    }

    #[test]
    fn every_kind_lists_params_inputs_and_outputs() {
        let all = kinds_json();
        let kinds = all["kinds"].as_array().unwrap();
        assert_eq!(kinds.len(), modalflow::stages::registry().len());
        for k in kinds {
            let params = k["params"].as_array().unwrap();
            assert!(!params.is_empty(), "{k}");
            for p in params {
                assert!(p["type"].as_str().is_some_and(|t| !t.is_empty()), "{p}");
                assert!(p["doc"].as_str().is_some_and(|d| !d.is_empty()), "{p}");
            }
            if k["kind"] != "command" {
                assert!(!k["outputs"].as_array().unwrap().is_empty(), "{k}");
            }
        }
    }

    #[test]
    fn types_defaults_and_ranges_come_from_the_structs() {
        let all = kinds_json();
        let gsa = kind(&all, "gsa");
        let samples = param(gsa, "samples");
        assert_eq!(samples["type"], "integer");
        assert_eq!(samples["default"], "1024");
        assert!(samples["range"].as_str().unwrap().starts_with("[2, "));
        assert_eq!(param(gsa, "threshold")["range"], "(0, 1)");
        let synth = kind(&all, "synthesize");
        assert_eq!(param(synth, "model")["required"], true);
        assert_eq!(param(synth, "quantity")["default"], "receptance");
        let ema = kind(&all, "autoema");
        let outputs: Vec<(&str, &str)> = ema["outputs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|o| (o["name"].as_str().unwrap(), o["artifact"].as_str().unwrap()))
            .collect();
        assert!(outputs.contains(&("modes", "modes")), "{outputs:?}");
        let frf = &ema["inputs"].as_array().unwrap()[0];
        assert_eq!(
            (frf["name"].as_str(), frf["artifact"].as_str()),
            (Some("frf"), Some("frf"))
        );
    }

    #[test]
    fn text_listing_shows_params_and_outputs() {
        let ws = Workspace::new();
        let out = ws.cmd(&["kinds", "gsa"]);
        let text = util::text(&out.stdout);
        assert!(
            text.contains("samples (integer; default 1024; range [2,"),
            "{text}"
        );
        assert!(text.contains("output significant (significant)"), "{text}");
        let out = ws.cmd(&["kinds", "nosuch"]);
        assert_eq!(out.status.code(), Some(2));
    }
}
