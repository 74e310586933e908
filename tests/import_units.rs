//! Units at import (issue 31): voltage or uncalibrated FRFs import with
//! `calibrated: false` or voltage `units`, marked so that stages needing a
//! physical scale refuse them while AutoEMA works; FRFs without any unit
//! label are a stage warning; errors name the line of the faulty record,
//! also in a late dataset.

use crate::util;

use modalflow::ema::synthetic::{four_mode_system, lines, modal_superposition};
use modalflow::frf::FrfSet;
use modalflow::io::{
    frf_sets_from_uff, read_frf_artifact_scaled, read_uff, uff58_from_frf_sets, write_frf_artifact,
    write_uff58, ByteOrder, FrfImportOptions, NumberText, Storage, Uff58, Uff58Format,
};
use util::{text, Workspace};

fn ascii() -> Uff58Format {
    Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::RoundTrip,
    }
}

/// Datasets 58 of the 4-mode system (10 FRFs), each with its units labels
/// set to `num`/`den` and ordinate type `ty`.
fn datasets(set: &FrfSet, num: &str, den: &str, ty: i32) -> Vec<Uff58> {
    let mut ds = uff58_from_frf_sets(std::slice::from_ref(set));
    for d in &mut ds {
        d.ordinate_axis.units = num.into();
        d.ordinate_axis.data_type = ty;
        d.denominator_axis.units = den.into();
    }
    ds
}

fn system(step: f64) -> FrfSet {
    modal_superposition(
        &four_mode_system(),
        &[0, 3],
        &lines(10.0, 270.0, step),
        0.0,
        1,
    )
}

/// 1-based line of the first line holding `needle`.
fn line_of(bytes: &[u8], needle: &str) -> usize {
    let at = bytes
        .windows(needle.len())
        .position(|w| w == needle.as_bytes())
        .unwrap();
    bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1
}

#[test]
fn an_error_in_a_late_dataset_names_that_records_line() {
    let set = system(5.0);
    for format in [
        ascii(),
        Uff58Format {
            storage: Storage::Binary(ByteOrder::Little),
            digits: NumberText::RoundTrip,
        },
    ] {
        let mut ds = datasets(&set, "m", "N", 8);
        assert_eq!(ds.len(), 10);
        ds[8].ordinate_axis.units = "furlong".into();
        ds[9].abscissa_axis.units = "RPM".into();
        let bytes = write_uff58(&ds, &format);
        let file = read_uff(&bytes, "run.uff").unwrap();
        let e = frf_sets_from_uff(&file, "run.uff", &FrfImportOptions::default())
            .unwrap_err()
            .to_string();
        let line = line_of(&bytes, "furlong");
        assert!(line > 100, "the fault is in a late dataset ({line})");
        assert!(
            e.contains(&format!("run.uff, line {line}:")) && e.contains("record 9"),
            "{e}"
        );
        // Record 8 of the last dataset, once record 9 is mended.
        ds[8].ordinate_axis.units = "m".into();
        let bytes = write_uff58(&ds, &format);
        let file = read_uff(&bytes, "run.uff").unwrap();
        let e = frf_sets_from_uff(&file, "run.uff", &FrfImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("line {}:", line_of(&bytes, "RPM"))),
            "{e}"
        );
    }
}

const VOLTS: &str = "name: volt\nstages:\n  volts:\n    kind: import\n    params: {path: volts.uff, calibrated: false}\n  volts_by_units:\n    kind: import\n    params: {path: volts.uff, units: {response: V, reference: V}}\n  model:\n    kind: import\n    params: {path: truth.uff}\n  ema:\n    kind: autoema\n    inputs: {frf: volts.frf}\n    params: {band: [20, 260], max_order: [8, 24], iterations: 24, initial: 10, fixed: {max_damping: 0.1}}\n  same_scale:\n    kind: evaluate\n    inputs: {reference_frf: volts.frf, candidate_frf: ema.frf_fit}\n  mixed:\n    kind: evaluate\n    inputs: {reference_frf: model.frf, candidate_frf: volts.frf}\n";

#[test]
fn voltage_frfs_import_uncalibrated_and_only_scale_free_uses_work() {
    let ws = Workspace::new();
    let set = system(0.25);
    // A voltage FRF: the receptance times an unknown sensitivity, in V/V.
    let mut volts = set.clone();
    for c in &mut volts.channels {
        c.values.iter_mut().for_each(|v| *v *= 1e3);
    }
    let bytes = write_uff58(&datasets(&volts, "V", "V", 0), &ascii());
    std::fs::write(ws.path().join("volts.uff"), &bytes).unwrap();
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();

    // Without the override it stays an error that names the fix.
    ws.write(
        "p.yaml",
        "name: volt\nstages:\n  volts:\n    kind: import\n    params: {path: volts.uff}\n",
    );
    let e = ws.run(&[], 1).stage("volts")["error"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        e.contains("calibrated: false") && e.contains(&format!("line {}", line_of(&bytes, "V "))),
        "{e}"
    );

    ws.write("p.yaml", VOLTS);
    let r = ws.run(&["--keep-going"], 1);
    for s in ["volts", "volts_by_units", "model", "ema", "same_scale"] {
        assert_eq!(r.status_of(s), "ran", "{s}: {:?}", r.stage(s));
    }
    assert!(r.stage("volts")["warnings"][0]
        .as_str()
        .unwrap()
        .contains("uncalibrated"));
    let e = r.stage("mixed")["error"].as_str().unwrap();
    assert!(
        e.contains("evaluate") && e.contains("uncalibrated") && e.contains("units:"),
        "{e}"
    );
    // Round trip: values as measured, bit for bit, and the mark kept.
    let artifact = std::fs::read(ws.path().join("results/volt/volts/frf.uff")).unwrap();
    let (back, calibrated) = read_frf_artifact_scaled(&artifact, "frf.uff").unwrap();
    assert!(!calibrated);
    assert_eq!(back[0].channels, volts.channels);
    let by_units = std::fs::read(ws.path().join("results/volt/volts_by_units/frf.uff")).unwrap();
    assert_eq!(artifact, by_units, "both overrides give one artifact");
    let summary: serde_json::Value = ws.json("results/volt/volts/import.json");
    assert_eq!(summary["calibrated"], false);
    // AutoEMA on voltage data: frequencies as on the calibrated data, and
    // its fitted FRFs keep the mark.
    let modes = ws.read("results/volt/ema/modes/modes.csv");
    let found: Vec<f64> = modes
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    for m in four_mode_system() {
        assert!(
            found
                .iter()
                .any(|f| (f - m.frequency_hz).abs() < 5e-3 * m.frequency_hz),
            "{} Hz not in {found:?}",
            m.frequency_hz
        );
    }
    let fit = std::fs::read(ws.path().join("results/volt/ema/frf_fit.uff")).unwrap();
    assert!(!read_frf_artifact_scaled(&fit, "frf_fit.uff").unwrap().1);
    let m: serde_json::Value = ws.json("results/volt/same_scale/metrics.json");
    assert!(m["frf"]["mean_frac"].as_f64().unwrap() > 0.99, "{m}");
}

#[test]
fn unlabelled_frfs_are_a_stage_warning_shown_on_the_command_line() {
    let ws = Workspace::new();
    let bytes = write_uff58(&datasets(&system(5.0), "NONE", "NONE", 0), &ascii());
    std::fs::write(ws.path().join("plain.uff"), bytes).unwrap();
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  plain:\n    kind: import\n    params: {path: plain.uff}\n",
    );
    let r = ws.run(&[], 0);
    let w = r.stage("plain")["warnings"][0].as_str().unwrap();
    assert!(
        w.contains("plain.uff: 10 FRF(s) have no units label") && w.contains("m/N"),
        "{w}"
    );
    // Shown as a warning line with `--progress lines`, also when cached.
    for _ in 0..2 {
        let out = ws.cmd(&["run", "p.yaml", "--progress", "lines"]);
        assert_eq!(out.status.code(), Some(0));
        let err = text(&out.stderr);
        assert!(
            err.contains("warning: stage plain: plain.uff: 10 FRF(s) have no units label"),
            "{err}"
        );
    }
    // Labelled files give no such warning.
    let bytes = write_uff58(&datasets(&system(5.0), "m", "N", 8), &ascii());
    std::fs::write(ws.path().join("plain.uff"), bytes).unwrap();
    let r = ws.run(&[], 0);
    assert!(r.stage("plain").get("warnings").is_none(), "{:?}", r.0);
}

#[test]
fn units_params_are_checked_before_running() {
    let ws = Workspace::new();
    std::fs::write(ws.path().join("a.uff"), write_frf_artifact(&[system(5.0)])).unwrap();
    for (params, needle) in [
        (
            "{path: a.uff, units: {response: furlong, reference: N}}",
            "furlong",
        ),
        (
            "{path: a.uff, units: {response: g, reference: N}, calibrated: false}",
            "contradicts",
        ),
        ("{path: a.uff, shapes: s.csv}", "content: modes"),
        (
            "{path: a.uff, content: modes, calibrated: false}",
            "applies to FRFs",
        ),
    ] {
        ws.write(
            "p.yaml",
            &format!("name: imp\nstages:\n  a:\n    kind: import\n    params: {params}\n"),
        );
        let out = ws.cmd(&["validate", "p.yaml"]);
        assert_eq!(out.status.code(), Some(2), "{params}");
        let err = text(&out.stderr);
        assert!(
            err.contains(needle) && err.contains("p.yaml"),
            "{params}: {err}"
        );
    }
}
