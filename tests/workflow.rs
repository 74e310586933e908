//! A user's study as one project (issue 29): files one stage writes and
//! another reads by path are DAG edges (export → import, command outs →
//! import), `--set` runs keep their results apart from the file's, the
//! project root is found from any subfolder, and validation reports file
//! problems in the same round as param problems.

use crate::util::{self, Report, Workspace};

const MODEL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/pipelines/models/three_mass.yaml"
);

/// A workspace with the three-mass model and `p.yaml` = `yaml`.
fn with_model(yaml: &str) -> Workspace {
    let ws = Workspace::new();
    let model = std::fs::read_to_string(MODEL).unwrap();
    ws.write("models/three_mass.yaml", &model);
    ws.write("p.yaml", yaml);
    ws
}

const EXPORT_IMPORT: &str = r#"name: loop
seed: 3
stages:
  truth:
    kind: synthesize
    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 400, step: 0.5}, noise: {relative: 0.01}}
  write:
    kind: export
    inputs: {frf: truth.frf}
    params: {to: data/machine}
  measured:
    kind: import
    params: {path: data/machine/frf.uff}
  copied:
    kind: command
    params: {cmd: "mkdir -p raw && cp data/machine/frf.uff raw/run1.uff", deps: [data/machine], outs: [raw]}
  again:
    kind: import
    params: {path: "raw/*.uff"}
"#;

#[test]
fn a_file_another_stage_writes_is_an_edge() {
    let ws = with_model(EXPORT_IMPORT);
    let dag = ws.cmd(&["dag", "p.yaml"]);
    let text = util::text(&dag.stdout);
    assert_eq!(dag.status.code(), Some(0), "{}", util::text(&dag.stderr));
    assert!(text.contains("measured (import) <- write"), "{text}");
    assert!(text.contains("again (import) <- copied"), "{text}");
    // One stage with what it needs, before the file exists.
    let r = ws.run(&["measured"], 0);
    assert_eq!(r.status_of("measured"), "ran");
    assert!(ws.path().join("data/machine/frf.uff").is_file());
    let r = ws.run(&[], 0);
    assert_eq!(r.status_of("again"), "ran");
    // The import reads the exported file: the same FRFs come back.
    let read = |p: &str| std::fs::read(ws.path().join(p)).unwrap();
    let (a, b) = (
        read("results/loop/measured/frf.uff"),
        read("results/loop/again/frf.uff"),
    );
    assert_eq!(a, b);
    // An edit upstream reruns the chain; the removed file is restored.
    std::fs::remove_dir_all(ws.path().join("data")).unwrap();
    assert!(ws.status().all("cached"));
    let r = ws.run(&[], 0);
    assert!(r.all("cached"), "{:?}", r.statuses());
    assert!(ws.path().join("data/machine/frf.uff").is_file());
}

const SMALL: &str = r#"name: small
stages:
  a:
    kind: command
    params: {cmd: "echo $((6 * 7)) > a.txt", outs: [a.txt]}
  b:
    kind: command
    params: {cmd: "cat a.txt > b.txt; echo n >> b.txt", deps: [a.txt], outs: [b.txt]}
"#;

#[test]
fn a_set_run_never_leaves_the_files_results_out_of_step() {
    let ws = with_model(SMALL);
    ws.run(&[], 0);
    let plain = ws.read("results/small/b/manifest.json");
    let out = ws.cmd(&[
        "run",
        "p.yaml",
        "--set",
        "b.cmd=echo other > b.txt",
        "--progress",
        "none",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    let said = util::text(&out.stdout);
    assert!(said.contains("results in small--set-"), "{said}");
    // The file's results are untouched; the declared output the --set run
    // wrote into the workspace is named, and a plain run puts it back.
    assert_eq!(ws.read("results/small/b/manifest.json"), plain);
    let status = ws.status();
    assert!(status.all("cached"), "{:?}", status.statuses());
    let reason = status.stage("b")["reason"].as_str().unwrap().to_string();
    assert!(
        reason.contains("`b.txt` in the workspace holds another run's output"),
        "{reason}"
    );
    ws.run(&[], 0);
    assert_eq!(ws.read("b.txt"), "42\nn\n");
    let status = ws.status();
    assert_eq!(status.stage("b")["reason"], "up to date");
    let runs = status.0["set_runs"].as_array().cloned().unwrap_or_default();
    assert_eq!(runs.len(), 1, "{}", status.0);
    assert_eq!(runs[0]["overrides"][0], "b.cmd=echo other > b.txt");
    let verify = ws.cmd(&["verify", "p.yaml", "--json"]);
    assert_eq!(
        verify.status.code(),
        Some(0),
        "{}",
        util::text(&verify.stdout)
    );
    // Results of another run in the file's folder (as an older version's
    // --set run left them) are never called up to date or clean.
    let set_dir = ws
        .path()
        .join("results")
        .join(runs[0]["results"].as_str().unwrap());
    let stale = ws.path().join("results/small/b");
    std::fs::remove_dir_all(&stale).unwrap();
    copy_dir(&set_dir.join("b"), &stale);
    let status = ws.status();
    let reason = status.stage("b")["reason"].as_str().unwrap().to_string();
    assert!(reason.contains("holds another run's results"), "{reason}");
    let verify = ws.cmd(&["verify", "p.yaml", "--json"]);
    assert_eq!(
        verify.status.code(),
        Some(1),
        "{}",
        util::text(&verify.stdout)
    );
    let v: serde_json::Value = serde_json::from_slice(&verify.stdout).unwrap();
    let b = v["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == "b")
        .cloned();
    assert_eq!(b.unwrap()["status"], "stale");
    // A plain run puts the file's results back.
    ws.run(&[], 0);
    assert_eq!(ws.read("results/small/b/manifest.json"), plain);
}

fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let dest = to.join(e.file_name());
        if e.path().is_dir() {
            copy_dir(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

#[test]
fn status_in_a_subfolder_finds_the_projects_cache() {
    let ws = Workspace::new();
    ws.write("pipelines/p.yaml", SMALL);
    let out = ws.cmd(&["run", "pipelines/p.yaml", "--progress", "none"]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    assert!(ws.path().join("cache/runs").is_dir());
    for sub in ["pipelines", "pipelines/deeper"] {
        std::fs::create_dir_all(ws.path().join(sub)).unwrap();
        let file = if sub == "pipelines" {
            "p.yaml"
        } else {
            "../p.yaml"
        };
        let out = ws
            .command(&["status", file, "--json"])
            .current_dir(ws.path().join(sub))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
        let r = Report(serde_json::from_slice(&out.stdout).unwrap());
        assert!(r.all("cached"), "{sub}: {:?}", r.statuses());
    }
    // gc from a subfolder finds the same cache (and keeps what the file uses).
    let out = ws
        .command(&["gc", "--json"])
        .current_dir(ws.path().join("pipelines/deeper"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    let gc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(gc["removed_objects"], 0, "{gc}");
    assert!(gc["kept_objects"].as_u64().unwrap_or(0) > 0, "{gc}");
    // Nothing was created in the subfolders.
    assert!(!ws.path().join("pipelines/cache").exists());
    assert!(!ws.path().join("pipelines/results").exists());
    assert!(!ws.path().join("pipelines/deeper/cache").exists());
    // A marker file names the root before any cache exists.
    let ws = Workspace::new();
    ws.write(".modalflow", "");
    ws.write("studies/p.yaml", SMALL);
    let out = ws
        .command(&["run", "p.yaml", "--progress", "none"])
        .current_dir(ws.path().join("studies"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    assert!(ws.path().join("cache/runs").is_dir());
    assert!(ws.path().join("results/small/b/b.txt").is_file());
    assert!(!ws.path().join("studies/cache").exists());
}

#[test]
fn validation_reports_files_with_params_in_one_round() {
    let ws = with_model(
        r#"name: round
stages:
  truth:
    kind: synthesize
    params: {model: models/missing.yaml, frequency: {min: 0, max: 400, step: 0.5}, colour: red}
  other:
    kind: import
    params: {path: data/none.uff, band: [-5, 10]}
"#,
    );
    let out = ws.cmd(&["validate", "p.yaml", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let problems: Vec<String> = v["problems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["message"].as_str().unwrap_or_default().to_string())
        .collect();
    let has = |needle: &str| problems.iter().any(|p| p.contains(needle));
    assert!(has("colour"), "{problems:#?}");
    assert!(has("models/missing.yaml"), "{problems:#?}");
    assert!(has("band"), "{problems:#?}");
    assert!(has("data/none.uff"), "{problems:#?}");
}

#[test]
fn kinds_prints_the_defaults_the_code_uses() {
    let ws = Workspace::new();
    let out = ws.cmd(&["kinds", "identify"]);
    let text = util::text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("pairing "))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(
        line.contains("\"window\":0.3") && line.contains("\"min_mac\":0.5"),
        "{line}"
    );
}

#[test]
fn an_impact_test_names_the_step_it_does_not_use() {
    let ws = with_model(
        "name: hammer\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/three_mass.yaml, frequency: {min: 0, max: 100, step: 1}, impact_test: {averages: 2}}\n",
    );
    let r = ws.run(&[], 0);
    let warnings = r.stage("truth")["warnings"].to_string();
    assert!(
        warnings.contains("frequency.step = 1 is not used"),
        "{warnings}"
    );
}
