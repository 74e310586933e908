//! One round trip per typed artifact kind: written through its schema,
//! read back equal; files of schema version 1 (fixtures written by the
//! previous release, `tests/fixtures/artifacts/`) read, and versions newer
//! than this build refused with the fix.

use super::*;
use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/artifacts")
        .join(name)
}

fn position(index: u32) -> Position {
    Position {
        index,
        label: format!("x={index}"),
    }
}

#[test]
fn frf_round_trips_with_its_scale_mark() {
    let dir = tempfile::tempdir().unwrap();
    let sets = vec![FrfSet {
        position: position(1),
        quantity: FrfQuantity::Mobility,
        frequencies_hz: vec![1.0, 2.0, 3.5],
        channels: vec![FrfChannel {
            response: Dof::new(2, -3),
            reference: Dof::new(1, 3),
            values: vec![
                Complex64::new(1e-6, -2e-7),
                Complex64::new(-3.25e-5, 0.0),
                Complex64::new(0.0, 7e-9),
            ],
            coherence: None,
        }],
    }];
    let path = dir.path().join(frf::FILE);
    for calibrated in [true, false] {
        frf::write_scaled(&path, &sets, calibrated).unwrap();
        let (back, cal) = frf::read_scaled(&path, "frf").unwrap();
        assert_eq!(cal, calibrated);
        assert_eq!(back[0].position, sets[0].position);
        assert_eq!(back[0].quantity, sets[0].quantity);
        assert_eq!(back[0].frequencies_hz, sets[0].frequencies_hz);
        assert_eq!(back[0].channels[0].values, sets[0].channels[0].values);
        assert_eq!(back[0].channels[0].response, sets[0].channels[0].response);
    }
    let e = frf::read_calibrated(&path, "reference", "identify", "the FRF refinement")
        .unwrap_err()
        .to_string();
    assert!(e.contains("uncalibrated") && e.contains("reference"), "{e}");
}

#[test]
fn modes_round_trip_with_scaling_and_spread() {
    let dir = tempfile::tempdir().unwrap();
    let models = vec![ModalModel {
        position: position(0),
        dofs: vec![Dof::new(1, 1), Dof::new(2, 1)],
        modes: vec![
            Mode {
                frequency_hz: 12.5,
                damping_ratio: 0.01,
                shape: vec![Complex64::new(1.0, 0.0), Complex64::new(-0.5, 0.25)],
            },
            Mode {
                frequency_hz: 40.125,
                damping_ratio: 0.02,
                shape: vec![Complex64::new(0.5, 0.0), Complex64::new(1.0, 0.0)],
            },
        ],
    }];
    let d = dir.path().join(modes::DIR);
    modes::write_mass_normalized_modes(&d, &models).unwrap();
    let back = modes::read_modes(&d, "modes").unwrap();
    assert_eq!(back, models);
    assert_eq!(
        modes::read_shape_scaling(&d, "modes").unwrap(),
        crate::modal::ShapeScaling::MassNormalized
    );
    let spread = [modes::ModeSpread {
        position: 0,
        mode: 2,
        frequency: 1e-3,
        damping: 0.2,
    }];
    modes::write_mode_spread(&d, &spread).unwrap();
    let text = std::fs::read_to_string(d.join("uncertainty.csv")).unwrap();
    assert!(text.starts_with("position,mode,frequency_std_rel,damping_std_rel\n"));
    assert_eq!(modes::read_mode_spread(&d, "m").unwrap().unwrap(), spread);
    // Version 1 of uncertainty.csv is read the same way.
    std::fs::write(
        d.join("uncertainty.csv"),
        "position,mode,frequency_spread,damping_spread\n0,2,0.001,0.2\n",
    )
    .unwrap();
    assert_eq!(modes::read_mode_spread(&d, "m").unwrap().unwrap(), spread);
}

#[test]
fn model_round_trips_and_old_files_read() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("models")).unwrap();
    std::fs::write(dir.path().join("models/k.mtx"), "1 1 1\n").unwrap();
    let m = model::ModelJson {
        schema_version: SchemaVersion(model::SCHEMA_VERSION),
        file: Some("m.yaml".into()),
        path: Some("models/m.yaml".into()),
        yaml: "parameters: {}\n".into(),
        files: vec![model::ReferencedFile::of("k.mtx", b"1 1 1\n")],
        external: Default::default(),
        parameters: vec![model::ModelParameter {
            name: "k".into(),
            value: 2e6,
            lower: 1e6,
            upper: 4e6,
            scale: "log".into(),
            kind: "stiffness".into(),
        }],
        positions: vec![model::ModelPosition {
            index: 0,
            label: String::new(),
        }],
        dofs: 9,
    };
    let path = dir.path().join(model::FILE);
    m.write(&path).unwrap();
    assert_eq!(model::ModelJson::read(&path, "model").unwrap(), m);
    // By reference: the recorded hash is blake3 of the content, and the
    // file is read beside the model file, below the pipeline directory.
    assert_eq!(
        m.files[0].blake3,
        blake3::hash(b"1 1 1\n").to_hex().to_string()
    );
    assert_eq!(m.files[0].bytes, 6);
    assert_eq!(m.resolver(dir.path())("k.mtx").unwrap(), b"1 1 1\n");
    assert!(m.resolver(dir.path())("other.mtx").is_err());
    // Version 2: referenced files embedded as text, still read.
    std::fs::write(
        &path,
        r#"{"schema_version": 2, "file": "m.yaml", "yaml": "x: 1\n", "external": {"k.mtx": "2 2 2\n"}}"#,
    )
    .unwrap();
    let v2 = model::ModelJson::read(&path, "model").unwrap();
    assert_eq!(v2.resolver(dir.path())("k.mtx").unwrap(), b"2 2 2\n");
    let all = v2.referenced(dir.path(), "model").unwrap();
    assert_eq!(all["k.mtx"], b"2 2 2\n");
    // Written again: the text is not carried over.
    v2.write(&path).unwrap();
    assert!(!std::fs::read_to_string(&path).unwrap().contains("2 2 2"));
    // Version 1: no schema_version.
    std::fs::write(&path, r#"{"file": "m.yaml", "yaml": "x: 1\n", "dofs": 3}"#).unwrap();
    let old = model::ModelJson::read(&path, "model").unwrap();
    assert_eq!(old.schema_version, SchemaVersion(1));
    assert_eq!(old.dofs, 3);
    // Not a model.json: refused naming the input and the fix.
    std::fs::write(&path, r#"{"nodes": []}"#).unwrap();
    let e = model::ModelJson::read(&path, "model")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("input `model`") && e.contains("synthesize"),
        "{e}"
    );
}

/// A referenced file edited after the synthesize stage ran is refused
/// with what changed and what to do, never used.
#[test]
fn a_changed_referenced_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("k.mtx"), "1 1 2\n").unwrap();
    let m = model::ModelJson {
        schema_version: SchemaVersion(model::SCHEMA_VERSION),
        file: Some("m.yaml".into()),
        path: Some("m.yaml".into()),
        yaml: String::new(),
        files: vec![model::ReferencedFile::of("k.mtx", b"1 1 1\n")],
        external: Default::default(),
        parameters: vec![],
        positions: vec![],
        dofs: 0,
    };
    let e = m.resolver(dir.path())("k.mtx").unwrap_err().to_string();
    assert!(
        e.contains("`k.mtx` changed since the synthesize stage ran")
            && e.contains("rerun the synthesize stage"),
        "{e}"
    );
    std::fs::remove_file(dir.path().join("k.mtx")).unwrap();
    let e = m.referenced(dir.path(), "model").unwrap_err().to_string();
    assert!(
        e.contains("input `model`") && e.contains("cannot read `k.mtx`"),
        "{e}"
    );
}

#[test]
fn newer_schema_versions_are_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(metrics::FILE);
    std::fs::write(&path, r#"{"schema_version": 99}"#).unwrap();
    let e = metrics::Metrics::read(&path).unwrap_err().to_string();
    assert!(
        e.contains("schema_version 99") && e.contains("update modalflow"),
        "{e}"
    );
}

#[test]
fn parameters_round_trip_both_row_types_and_read_version_1() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(parameters::FILE);
    let truth = vec![parameters::TruthRow {
        parameter: "k1".into(),
        value: 1.5e6,
        lower: 1e6,
        upper: 3e6,
        scale: "log".into(),
        kind: "stiffness".into(),
    }];
    parameters::write(&path, &truth).unwrap();
    assert_eq!(parameters::read_truth(&path).unwrap(), truth);
    assert_eq!(
        parameters::read_values(&path, "truth").unwrap(),
        [("k1".to_string(), 1.5e6)].into()
    );
    // The previous release's identify table: old column names.
    let old = parameters::read_identified(&fixture("parameters_v1.csv")).unwrap();
    assert_eq!(old.len(), 78);
    let k_y = old.iter().find(|r| r.parameter == "me1.k_y").unwrap();
    assert_eq!(k_y.std_error_rel, Some(0.011558421690009332));
    assert_eq!(k_y.identifiable, Some(true));
    parameters::write(&path, &old).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with(
        "parameter,value,lower,upper,initial,identified,identifiable,std_error_rel,\
         std_error_with_fixed_rel,ci_low,ci_high,score,implicated,suggested_change_rel\n"
    ));
    assert_eq!(parameters::read_identified(&path).unwrap(), old);
    // A value that is not finite is refused, naming the input and line.
    std::fs::write(&path, "parameter,value\nk,NaN\n").unwrap();
    let e = parameters::read_values(&path, "values")
        .unwrap_err()
        .to_string();
    assert!(e.contains("input `values`") && e.contains("line 2"), "{e}");
}

#[test]
fn json_summaries_of_version_1_read_and_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let c = cost::Cost::read(&fixture("cost_v1.json")).unwrap();
    assert_eq!(c.schema_version, SchemaVersion(1));
    let path = dir.path().join(cost::FILE);
    c.write(&path).unwrap();
    let back = cost::Cost::read(&path).unwrap();
    assert_eq!(back.schema_version, SchemaVersion(cost::SCHEMA_VERSION));
    assert_eq!(back.verdict, c.verdict);
    assert_eq!(back.evaluations, c.evaluations);

    let i =
        identifiability::IdentifiabilityFile::read(&fixture("identifiability_v1.json")).unwrap();
    let path = dir.path().join(identifiability::FILE);
    i.write(&path).unwrap();
    let back = identifiability::IdentifiabilityFile::read(&path).unwrap();
    // NaN ≠ NaN: compare as JSON (NaN is null there).
    let json =
        |a: &identifiability::IdentifiabilityFile| serde_json::to_value(&a.analysis).unwrap();
    assert_eq!(json(&back), json(&i));
    assert_eq!(back.assumptions, i.assumptions);

    let m = metrics::Metrics {
        parameters: Some(metrics::ParameterMetrics {
            parameters: 3,
            mean_abs_relative_error: Some(0.01),
            max_abs_relative_error: None,
        }),
        verdict: Some(c.verdict.clone()),
        ..Default::default()
    };
    let path = dir.path().join(metrics::FILE);
    m.write(&path).unwrap();
    let back = metrics::Metrics::read(&path).unwrap();
    assert_eq!(back.schema_version, SchemaVersion(metrics::SCHEMA_VERSION));
    assert_eq!(
        metrics::Metrics {
            schema_version: SchemaVersion(1),
            ..back
        },
        m
    );
}

#[test]
fn identify_tables_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let rows = correlation::read(&fixture("correlation.csv")).unwrap();
    assert!(rows.len() > 3 && rows[0].used);
    let path = dir.path().join(correlation::FILE);
    correlation::write(&path, &rows).unwrap();
    assert_eq!(correlation::read(&path).unwrap(), rows);

    let history = history::read(&fixture("history.csv")).unwrap();
    assert!(!history.is_empty());
    let path = dir.path().join(history::FILE);
    history::write(&path, &history).unwrap();
    assert_eq!(history::read(&path).unwrap(), history);
}

#[test]
fn significant_round_trips_and_reads_the_short_form() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(significant::FILE);
    let rows = vec![
        significant::SignificantRow {
            parameter: "k1".into(),
            score: 0.25,
            score_low: Some(0.2),
            score_high: Some(0.3),
            undecided: Some(false),
            samples_needed: None,
            significant: true,
        },
        significant::SignificantRow {
            parameter: "c1".into(),
            score: 0.001,
            score_low: Some(0.0),
            score_high: Some(0.0125),
            undecided: Some(true),
            samples_needed: Some(4096),
            significant: false,
        },
    ];
    significant::write(&path, &rows).unwrap();
    assert_eq!(significant::read(&path, "significant").unwrap(), rows);
    // Before gsa 8: three columns.
    std::fs::write(&path, "parameter,score,significant\nk1,0.25,true\n").unwrap();
    let short = significant::read(&path, "significant").unwrap();
    assert_eq!(short[0].score_low, None);
    assert!(short[0].significant);
}

/// The Python package refuses a JSON artifact newer than its table of
/// schema versions: the table must name what this build writes, or every
/// file of that kind fails to load in Python (cost.json stood at 2 there
/// while this build wrote 3).
#[test]
fn the_python_package_reads_the_schema_versions_this_build_writes() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("python/modalflow/artifacts.py")).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("SCHEMA_VERSIONS = {"))
        .unwrap();
    for (file, version) in [
        (metrics::FILE, metrics::SCHEMA_VERSION),
        (cost::FILE, cost::SCHEMA_VERSION),
        (identifiability::FILE, identifiability::SCHEMA_VERSION),
        (model::FILE, model::SCHEMA_VERSION),
    ] {
        let entry = format!("\"{file}\": {version}");
        assert!(line.contains(&entry), "{entry} not in {line}");
    }
}
