//! Large matrices by reference (issue 32): a synthesize stage's model.json
//! names the super-element's matrix files by path, size and blake3 and holds
//! none of their text; identify rebuilds the model from the files beside the
//! model file, and its updated model refers to them too; a file edited after
//! the synthesize stage ran is refused with what to do, and a rerun follows
//! the edit; validation reads a built model's facts from the cache.

use crate::util::Workspace;
use modalflow::artifacts::model::{ModelJson, SCHEMA_VERSION};
use modalflow::dynamics::Model;

/// Two nodes joined by an element in each direction, each grounded by the
/// parameter k.
const MODEL: &str = r#"
parameters:
  - {name: k, value: 1.0e6, lower: 1.0e5, upper: 1.0e7, scale: log, kind: stiffness}
  - {name: c, value: 40.0, lower: 10.0, upper: 160.0, scale: log, kind: damping}
bodies:
  - name: se
    superelement:
      mass: se/m.mtx
      stiffness: se/k.mtx
      nodes:
        - {id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}
        - {id: 2, dofs: [3, 4, 5], position: [1, 0, 0]}
      points: {a: {node: 1}, b: {node: 2}}
joints:
  - {name: s1, a: {body: se, point: a}, connections: [{dir: x, stiffness: k, damper: c}, {dir: y, stiffness: k, damper: c}, {dir: z, stiffness: k, damper: c}]}
  - {name: s2, a: {body: se, point: b}, connections: [{dir: x, stiffness: k, damper: c}, {dir: y, stiffness: k, damper: c}, {dir: z, stiffness: k, damper: c}]}
sensors:
  - {name: a, body: se, point: a, node: 1, direction: 1}
  - {name: b, body: se, point: b, node: 2, direction: 1}
  - {name: ay, body: se, point: a, node: 1, direction: 2}
  - {name: by, body: se, point: b, node: 2, direction: 2}
  - {name: az, body: se, point: a, node: 1, direction: 3}
  - {name: bz, body: se, point: b, node: 2, direction: 3}
excitations:
  - {name: b, body: se, point: b, node: 2, direction: 1}
  - {name: by, body: se, point: b, node: 2, direction: 2}
  - {name: bz, body: se, point: b, node: 2, direction: 3}
"#;

const PIPELINE: &str = "name: byref\nstages:\n  truth:\n    kind: synthesize\n    params: {model: models/se.yaml, frequency: {min: 0, max: 600, step: 0.5}, values: {k: 1.3e6}}\n  fit:\n    kind: identify\n    inputs: {model: truth.model, reference: truth.modes}\n    params: {strategy: black_box, optimizer: slsqp, budget: 800, window: 0.3}\n";

/// A symmetric Matrix Market matrix of the two 3-DOF nodes: `diag` on the
/// diagonal and `off` between the nodes, scaled per direction by
/// `scale` (distinct directions: no repeated modes).
fn mm(diag: f64, off: f64, scale: [f64; 3]) -> String {
    let mut s = String::from("%%MatrixMarket matrix coordinate real symmetric\n6 6 9\n");
    for i in 1..=6 {
        s += &format!("{i} {i} {:e}\n", diag * scale[(i - 1) % 3]);
    }
    for i in 1..=3 {
        s += &format!("{} {i} {:e}\n", i + 3, off * scale[i - 1]);
    }
    s
}

fn mass() -> String {
    mm(1.0, 0.0, [1.0, 1.3, 1.7])
}

fn stiffness(diag: f64) -> String {
    mm(diag, -2.0e6, [1.0, 1.5, 2.2])
}

fn workspace() -> Workspace {
    let ws = Workspace::new();
    ws.write("p.yaml", PIPELINE);
    ws.write("models/se.yaml", MODEL);
    ws.write("models/se/m.mtx", &mass());
    ws.write("models/se/k.mtx", &stiffness(2.0e6));
    ws
}

/// Every file below `dir` (relative path, bytes).
fn files_below(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out
}

#[test]
fn model_json_refers_to_the_matrices_and_holds_none_of_their_text() {
    let ws = workspace();
    ws.run(&[], 0);
    let text = ws.read("results/byref/truth/model.json");
    let raw: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(raw["schema_version"], SCHEMA_VERSION);
    assert!(raw.get("external").is_none(), "{text}");
    assert_eq!(raw["path"], "models/se.yaml");
    let json = ModelJson::read(&ws.path().join("results/byref/truth/model.json"), "m").unwrap();
    let mut listed: Vec<(String, u64, String)> = json
        .files
        .iter()
        .map(|f| (f.path.clone(), f.bytes, f.blake3.clone()))
        .collect();
    listed.sort();
    let expect = |rel: &str, text: String| {
        let hash = blake3::hash(text.as_bytes()).to_hex().to_string();
        (rel.to_string(), text.len() as u64, hash)
    };
    assert_eq!(
        listed,
        vec![
            expect("se/k.mtx", stiffness(2.0e6)),
            expect("se/m.mtx", mass()),
        ]
    );
    // No output of any stage holds the matrix text (its banner, or an
    // entry line), neither in results/ nor in the cache: the pipeline
    // folder holds the one copy.
    let stiffness_line = "4 1 -2e6\n";
    let holds = |b: &[u8]| {
        let t = String::from_utf8_lossy(b);
        t.contains("%%MatrixMarket") || t.contains(stiffness_line)
    };
    for dir in ["results/byref", "cache"] {
        for (rel, bytes) in files_below(&ws.path().join(dir)) {
            assert!(!holds(&bytes), "{dir}/{rel} holds matrix text");
        }
    }
    // identify's updated model names the input's matrices (size, blake3)
    // and says how to run it; beside the input model file it reproduces
    // the identification's updated modes.
    let updated = ws.read("results/byref/fit/updated_model/model.yaml");
    let k = expect("se/k.mtx", stiffness(2.0e6));
    assert!(
        updated.contains(&format!("se/k.mtx ({} bytes, blake3 {})", k.1, &k.2[..16]))
            && updated.contains("place it beside models/se.yaml")
            && updated.contains("inputs: {values: fit.parameters}"),
        "{updated}"
    );
    assert!(!ws
        .path()
        .join("results/byref/fit/updated_model/se")
        .exists());
    ws.write("models/se_updated.yaml", &updated);
    ws.write(
        "p.yaml",
        "name: again\nstages:\n  again:\n    kind: synthesize\n    params: {model: models/se_updated.yaml, frequency: {min: 0, max: 600, step: 0.5}}\n",
    );
    ws.run(&[], 0);
    crate::util::assert_same_frequencies(
        &ws.frequencies("results/byref/fit/modes/modes.csv"),
        &ws.frequencies("results/again/again/modes/modes.csv"),
        6,
    );
}

#[test]
fn a_matrix_edited_after_synthesize_is_refused_then_rerun() {
    let ws = workspace();
    ws.run(&[], 0);
    let path = ws.path().join("results/byref/truth/model.json");
    let json = ModelJson::read(&path, "model").unwrap();
    let name = json.file_name("model.yaml");
    // As identify builds it: from the files beside the model file.
    let model = Model::from_yaml(&json.yaml, name, &json.resolver(ws.path())).unwrap();
    assert_eq!(model.n_dofs(), 6);
    ws.write("models/se/k.mtx", &stiffness(2.5e6));
    let e = Model::from_yaml(&json.yaml, name, &json.resolver(ws.path()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("se/k.mtx")
            && e.contains("changed since the synthesize stage ran")
            && e.contains("rerun the synthesize stage"),
        "{e}"
    );
    let e = json.referenced(ws.path(), "model").unwrap_err().to_string();
    assert!(
        e.contains("input `model`") && e.contains("changed since"),
        "{e}"
    );
    // The file is part of the synthesize key: a run reruns it and the new
    // model.json refers to the new content.
    ws.run(&[], 0);
    let again = ModelJson::read(&path, "model").unwrap();
    let k = again.files.iter().find(|f| f.path == "se/k.mtx").unwrap();
    let now = blake3::hash(stiffness(2.5e6).as_bytes())
        .to_hex()
        .to_string();
    assert_eq!(k.blake3, now);
    Model::from_yaml(&again.yaml, name, &again.resolver(ws.path())).unwrap();
}

/// The facts files of model files in the workspace's cache (name, JSON).
fn model_facts(ws: &Workspace) -> Vec<(String, serde_json::Value)> {
    let dir = ws.path().join("cache/models");
    let mut out: Vec<(String, serde_json::Value)> = files_below(&dir)
        .into_iter()
        .filter(|(name, _)| name.ends_with(".json"))
        .map(|(name, b)| (name, serde_json::from_slice(&b).unwrap()))
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// Validation of a model that built before reads its facts from the cache
/// instead of building it again (a 190k-DOF export: 0.2 instead of 7 CPU-s);
/// the facts are keyed by content, so an edited matrix is built and
/// checked again, and `validate` on a project without a cache creates none.
#[test]
fn validation_reads_the_facts_of_a_model_that_built_before() {
    let ws = workspace();
    ws.cmd_exit(&["validate", "p.yaml"], 0);
    assert!(!ws.path().join("cache").exists());
    ws.run(&[], 0);
    let facts = model_facts(&ws);
    assert_eq!(facts.len(), 1, "{facts:?}");
    let (name, json) = &facts[0];
    assert_eq!(json["n_dofs"], 6);
    assert_eq!(json["finite_modes"], 6);
    assert_eq!(json["parameters"][0]["name"], "k");
    assert_eq!(format!("{}.json", json["key"].as_str().unwrap()), *name);
    // Facts that say the model is too large for memory: validation believes
    // them (it did not build the model), and says what to do.
    let mut big = json.clone();
    big["memory_bytes"] = serde_json::json!(1.0e15);
    let path = ws.path().join("cache/models").join(name);
    std::fs::write(&path, serde_json::to_vec(&big).unwrap()).unwrap();
    let err = ws.cmd_exit(&["validate", "p.yaml"], 2);
    assert!(err.contains("memory"), "{err}");
    // The same facts under another content: an edited matrix is built
    // again (valid), and its own facts join the first.
    ws.write("models/se/k.mtx", &stiffness(2.5e6));
    ws.cmd_exit(&["validate", "p.yaml"], 0);
    assert_eq!(model_facts(&ws).len(), 2);
    // A model that does not build has no facts; its error stays.
    ws.write(
        "models/se/k.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n6 6 1\n9 9 1.0\n",
    );
    let err = ws.cmd_exit(&["validate", "p.yaml"], 2);
    assert!(err.contains("k.mtx"), "{err}");
    assert_eq!(model_facts(&ws).len(), 2);
    // `gc` collects them (found again by building).
    ws.cmd_exit(&["gc"], 0);
    assert!(model_facts(&ws).is_empty());
}
