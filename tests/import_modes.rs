//! Reference modes at import (issue 31): `content: modes` reads a
//! modes.csv table (damping and shapes optional) or UFF 55 into a `modes`
//! artifact, and `evaluate` compares AutoEMA's modes with them.

use crate::util;

use modalflow::ema::synthetic::{dof, four_mode_system, lines, modal_superposition};
use modalflow::frf::Position;
use modalflow::io::{
    read_modal_csv, uff55_from_modal_models, write_frf_artifact, write_modal_csv, write_uff55,
    NumberText,
};
use modalflow::modal::{ModalModel, Mode, ShapeScaling};
use num_complex::Complex64;
use util::Workspace;

/// The 4-mode test system as a modal model at its 5 DOFs.
fn reference_model() -> ModalModel {
    let modes = four_mode_system();
    ModalModel {
        position: Position::default(),
        dofs: (0..5).map(dof).collect(),
        modes: modes
            .iter()
            .map(|m| Mode {
                frequency_hz: m.frequency_hz,
                damping_ratio: m.damping_ratio,
                shape: m.shape.iter().map(|&x| Complex64::new(x, 0.0)).collect(),
            })
            .collect(),
    }
}

fn read_artifact(ws: &Workspace, stage: &str) -> Vec<ModalModel> {
    let dir = format!("results/ref/{stage}/modes");
    let modes = ws.read(&format!("{dir}/modes.csv"));
    let shapes = ws.read(&format!("{dir}/mode_shapes.csv"));
    read_modal_csv(
        modes.as_bytes(),
        "modes.csv",
        shapes.as_bytes(),
        "shapes.csv",
    )
    .unwrap()
}

#[test]
fn reference_modes_round_trip_from_csv_and_uff55() {
    let ws = Workspace::new();
    let two = |index: u32, label: &str| {
        let mut m = reference_model();
        m.position = Position {
            index,
            label: label.into(),
        };
        m.modes[1].shape[2] = Complex64::new(0.25, -0.125);
        m
    };
    let mut models = vec![two(0, "wpt=0.1"), two(2, "wpt=0.3")];
    let uff = write_uff55(
        &uff55_from_modal_models(&models, ShapeScaling::Arbitrary).unwrap(),
        NumberText::RoundTrip,
    );
    std::fs::write(ws.path().join("testlab.uff"), uff).unwrap();
    models[1].modes[3].damping_ratio = f64::NAN; // not given
    let csv = write_modal_csv(&models).unwrap();
    std::fs::write(ws.path().join("ref.csv"), &csv.modes).unwrap();
    std::fs::write(ws.path().join("ref_shapes.csv"), &csv.mode_shapes).unwrap();
    ws.write("published.csv", "mode,frequency_hz\n1,60\n2,95.5\n");
    ws.write(
        "p.yaml",
        "name: ref\nstages:\n  csv:\n    kind: import\n    params: {path: ref.csv, shapes: ref_shapes.csv, content: modes}\n  uff:\n    kind: import\n    params: {path: testlab.uff, content: modes}\n  published:\n    kind: import\n    params: {path: published.csv, content: modes, band: [0, 90]}\n",
    );
    let r = ws.run(&[], 0);
    // CSV: the same bytes back (one modes.csv shape), damping left empty.
    assert_eq!(
        ws.read("results/ref/csv/modes/modes.csv").as_bytes(),
        csv.modes
    );
    assert_eq!(
        ws.read("results/ref/csv/modes/mode_shapes.csv").as_bytes(),
        csv.mode_shapes
    );
    let back = read_artifact(&ws, "csv");
    assert!(back[1].modes[3].damping_ratio.is_nan());
    assert_eq!(back[0], models[0]);
    assert!(r.stage("csv")["warnings"][0]
        .as_str()
        .unwrap()
        .contains("1 mode(s) without a damping ratio"));
    // UFF 55 as Test.Lab writes it (three translations per node, zeros
    // where the model has none): exact through modalflow's reader.
    models[1].modes[3].damping_ratio = 0.02;
    let from_uff: Vec<ModalModel> = read_artifact(&ws, "uff")
        .into_iter()
        .map(|mut m| {
            let keep: Vec<usize> = (0..m.dofs.len())
                .filter(|&i| m.dofs[i].direction == 3)
                .collect();
            m.dofs = keep.iter().map(|&i| m.dofs[i]).collect();
            for mode in &mut m.modes {
                mode.shape = keep.iter().map(|&i| mode.shape[i]).collect();
            }
            m
        })
        .collect();
    assert_eq!(from_uff, models);
    // Published values: frequencies only, inside the band.
    assert_eq!(
        ws.read("results/ref/published/modes/modes.csv"),
        "position,position_label,mode,frequency_hz,damping_ratio\n0,,1,60,\n"
    );
    assert_eq!(
        ws.read("results/ref/published/modes/mode_shapes.csv"),
        "position,mode,node,direction,real,imag\n"
    );
    assert_eq!(r.stage("published")["counters"]["modes"], 1);
}

const PIPELINE: &str = "name: ref\nstages:\n  measured:\n    kind: import\n    params: {path: truth.uff}\n  ema:\n    kind: autoema\n    inputs: {frf: measured.frf}\n    params: {band: [20, 260], max_order: [8, 24], iterations: 24, initial: 10, fixed: {max_damping: 0.1}}\n  other_tool:\n    kind: import\n    params: {path: other.csv, shapes: other_shapes.csv, content: modes}\n  testlab:\n    kind: import\n    params: {path: testlab.uff, content: modes}\n  published:\n    kind: import\n    params: {path: published.csv, content: modes}\n  vs_other:\n    kind: evaluate\n    inputs: {reference: other_tool.modes, candidate: ema.modes}\n  vs_testlab:\n    kind: evaluate\n    inputs: {reference: testlab.modes, candidate: ema.modes}\n  vs_published:\n    kind: evaluate\n    inputs: {reference: published.modes, candidate: ema.modes}\n";

#[test]
fn evaluate_compares_autoema_with_imported_reference_modes() {
    let ws = Workspace::new();
    let set = modal_superposition(
        &four_mode_system(),
        &[0, 3],
        &lines(10.0, 270.0, 0.25),
        0.005,
        5,
    );
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    let model = reference_model();
    let csv = write_modal_csv(std::slice::from_ref(&model)).unwrap();
    std::fs::write(ws.path().join("other.csv"), &csv.modes).unwrap();
    std::fs::write(ws.path().join("other_shapes.csv"), &csv.mode_shapes).unwrap();
    let uff = write_uff55(
        &uff55_from_modal_models(std::slice::from_ref(&model), ShapeScaling::Arbitrary).unwrap(),
        NumberText::Standard,
    );
    std::fs::write(ws.path().join("testlab.uff"), uff).unwrap();
    ws.write(
        "published.csv",
        "mode,frequency_hz,damping_ratio\n1,60.0,\n2,95.0,0.015\n3,140.0,\n4,210.0,\n",
    );
    ws.write("p.yaml", PIPELINE);
    let r = ws.run(&[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    let metrics = |stage: &str| -> serde_json::Value {
        ws.json(&format!("results/ref/{stage}/metrics.json"))
    };
    for stage in ["vs_other", "vs_testlab"] {
        let m = &metrics(stage)["modes"];
        assert_eq!(m["paired"], 4, "{stage}: {m}");
        assert!(m["mean_mac"].as_f64().unwrap() > 0.99, "{stage}: {m}");
        assert!(m["mean_nfd"].as_f64().unwrap() < 5e-3, "{stage}: {m}");
        assert!(m["mean_ndd"].as_f64().unwrap() < 0.2, "{stage}: {m}");
        assert!(m.get("notes").is_none(), "{stage}: {m}");
    }
    // Published frequencies without shapes and mostly without damping:
    // paired by frequency, no MAC, NDD of the one mode that has damping.
    let m = &metrics("vs_published")["modes"];
    assert_eq!(m["paired"], 4, "{m}");
    assert!(
        m["mean_mac"].is_null() && m["mean_nfd"].as_f64().unwrap() < 5e-3,
        "{m}"
    );
    assert!(m["mean_ndd"].as_f64().unwrap() < 0.2, "{m}");
    let notes = m["notes"].to_string();
    assert!(
        notes.contains("paired by frequency alone")
            && notes.contains("3 pair(s) without a damping"),
        "{notes}"
    );
    let pairs = ws.read("results/ref/vs_published/tables/pairs.csv");
    let first: Vec<&str> = pairs.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(
        (first[6], first[8], first[9], first[10]),
        ("", "", "", ""),
        "{pairs}"
    );
}
