//! The import's `coherence` param (issue 31) on the measured set that
//! needs it: vibration-toolbox case 1 (MIT, `benchmarks/real_sets`), whose
//! stored γ² exceeds 1 on 5 lines below 18 Hz (1.246 at 0 Hz).

use crate::util::{self, Workspace};
use modalflow::io::read_frf_artifact;

const SET: &str = "benchmarks/real_sets/vibration_toolbox_cases/case1_with_coherence.uff";

/// A workspace holding the case-1 file and a pipeline of one import stage
/// `imp` with `params` added to its path.
fn workspace(params: &str) -> Workspace {
    let ws = Workspace::new();
    ws.copy_in(SET, "case1.uff");
    write_pipeline(&ws, params);
    ws
}

fn write_pipeline(ws: &Workspace, params: &str) {
    ws.write(
        "p.yaml",
        &format!(
            "name: coh\nstages:\n  imp: {{kind: import, params: {{path: case1.uff, calibrated: false{params}}}}}\n"
        ),
    );
}

fn coherence(ws: &Workspace) -> Option<Vec<f64>> {
    let bytes = std::fs::read(ws.path().join("results/coh/imp/frf.uff")).unwrap();
    let sets = read_frf_artifact(&bytes, "frf.uff").unwrap();
    assert_eq!((sets.len(), sets[0].channels.len()), (1, 1));
    sets[0].channels[0].coherence.clone()
}

fn import_json(ws: &Workspace) -> serde_json::Value {
    ws.json("results/coh/imp/import.json")
}

#[test]
fn the_default_refuses_coherence_above_one_and_says_how_to_import_it() {
    let ws = workspace("");
    let r = ws.run(&[], 1);
    let e = r.stage("imp")["error"].as_str().unwrap();
    assert!(
        e.contains("case1.uff, line 829") && e.contains("coherence 1.24622261524"),
        "{e}"
    );
    assert!(
        e.contains("`coherence: clamp`") && e.contains("`coherence: ignore`"),
        "{e}"
    );
    // The same in the human report: exit code 1, the fix in the message.
    let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
    let text = util::text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("coherence: clamp"), "{text}");
}

#[test]
fn clamp_imports_the_coherence_in_zero_one_with_one_warning() {
    let ws = workspace(", coherence: clamp");
    let r = ws.run(&[], 0);
    let gamma = coherence(&ws).expect("coherence kept");
    assert_eq!(gamma.len(), 1601);
    assert!(gamma.iter().all(|g| (0.0..=1.0).contains(g)));
    assert_eq!(gamma[0], 1.0, "1.246 at 0 Hz clamped");
    let warnings: Vec<&str> = r.stage("imp")["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let clamped: Vec<&&str> = warnings.iter().filter(|w| w.contains("clamped")).collect();
    assert_eq!(clamped.len(), 1, "{warnings:#?}");
    let w = clamped[0];
    assert!(
        w.contains("5 line(s) in 1 FRF(s)")
            && w.contains("1.24622261524")
            && w.contains("0–17.8125 Hz"),
        "{w}"
    );
    let c = &import_json(&ws)["coherence"];
    assert_eq!(c["policy"], "clamp");
    assert_eq!(c["clamped"]["lines"], 5);
    assert_eq!(c["clamped"]["band_hz"], serde_json::json!([0.0, 17.8125]));
    // What the stage does with coherence changes its key through the param.
    write_pipeline(&ws, ", coherence: ignore");
    let status = ws.status();
    assert_eq!(status.status_of("imp"), "will-run");
    assert!(
        status.stage("imp")["reason"]
            .as_str()
            .unwrap()
            .contains("coherence"),
        "{}",
        status.stage("imp")
    );
}

#[test]
fn ignore_imports_the_frf_without_coherence() {
    let ws = workspace(", coherence: ignore");
    let r = ws.run(&[], 0);
    assert_eq!(coherence(&ws), None);
    let j = import_json(&ws);
    assert_eq!(j["positions"][0]["coherence"], false);
    assert_eq!(j["coherence"]["policy"], "ignore");
    let warnings = r.stage("imp")["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .all(|w| !w.as_str().unwrap().contains("clamped")),
        "{warnings:?}"
    );
}

/// `coherence` is an FRF param: with reference modes it is refused at
/// validation, and a value outside the three is named.
#[test]
fn coherence_param_is_validated() {
    let ws = workspace(", coherence: clip");
    let stderr = ws.cmd_exit(&["validate", "p.yaml"], 2);
    assert!(stderr.contains("one of: check, clamp, ignore"), "{stderr}");
    ws.write("ref.csv", "mode,frequency_hz\n1,10\n");
    ws.write(
        "p.yaml",
        "name: coh\nstages:\n  imp: {kind: import, params: {path: ref.csv, content: modes, coherence: clamp}}\n",
    );
    let stderr = util::text(&ws.cmd(&["validate", "p.yaml"]).stderr);
    assert!(stderr.contains("`coherence` applies to FRFs"), "{stderr}");
}
