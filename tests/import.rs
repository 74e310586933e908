//! The `import` stage through the CLI: UFF and CSV measurements become the
//! `frf` artifact; selections, bands, globs and bad files.

use crate::util;

use modalflow::io::read_frf_artifact;
use util::Workspace;

const FIXTURES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/uff");

fn copy_fixture(ws: &Workspace, name: &str) {
    std::fs::copy(format!("{FIXTURES}/{name}"), ws.path().join(name)).unwrap();
}

fn artifact(ws: &Workspace, stage: &str) -> Vec<modalflow::frf::FrfSet> {
    let bytes = std::fs::read(ws.path().join(format!("results/imp/{stage}/frf.uff"))).unwrap();
    read_frf_artifact(&bytes, "frf.uff").unwrap()
}

#[test]
fn imports_uff_into_the_frf_artifact_with_selection_and_band() {
    let ws = Workspace::new();
    copy_fixture(&ws, "frf_58b_le.uff");
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  all:\n    kind: import\n    params: {path: frf_58b_le.uff}\n  cut:\n    kind: import\n    params: {path: frf_58b_le.uff, band: [22, 25], select: {responses: ['*'], references: ['*']}}\n",
    );
    ws.run(&[], 0);
    let all = artifact(&ws, "all");
    assert_eq!(all.len(), 1);
    assert_eq!(all[0].channels.len(), 2);
    assert_eq!(all[0].frequencies_hz.len(), 40);
    let cut = artifact(&ws, "cut");
    assert!(cut[0]
        .frequencies_hz
        .iter()
        .all(|&f| (22.0..=25.0).contains(&f)));
    assert_eq!(
        cut[0].frequencies_hz.len(),
        13,
        "0.25 Hz lines from 22 to 25 inclusive"
    );
    // The band keeps values bit for bit.
    let off = all[0]
        .frequencies_hz
        .iter()
        .position(|&f| f == 22.0)
        .unwrap();
    assert_eq!(
        cut[0].channels[0].values[..],
        all[0].channels[0].values[off..off + 13]
    );
}

#[test]
fn a_glob_of_files_gives_one_position_per_file_and_keeps_coherence() {
    let ws = Workspace::new();
    copy_fixture(&ws, "frf_ascii_4e20.uff");
    copy_fixture(&ws, "frf_ascii_6e13.uff");
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  runs:\n    kind: import\n    params: {path: 'frf_ascii_*.uff'}\n",
    );
    let r = ws.run(&[], 0);
    assert_eq!(r.stage("runs")["counters"]["positions"], 2);
    let sets = artifact(&ws, "runs");
    let labels: Vec<&str> = sets.iter().map(|s| s.position.label.as_str()).collect();
    assert_eq!(labels, ["frf_ascii_4e20", "frf_ascii_6e13"]);
    assert!(sets[0].channels[0].coherence.is_some());
    // Adding a third matching file changes the key: the stage reruns.
    copy_fixture(&ws, "frf_crlf.uff");
    std::fs::rename(
        ws.path().join("frf_crlf.uff"),
        ws.path().join("frf_ascii_crlf.uff"),
    )
    .unwrap();
    let status = ws.status();
    assert_eq!(status.status_of("runs"), "will-run");
    assert!(status.stage("runs")["reason"]
        .as_str()
        .unwrap()
        .contains("file frf_ascii_crlf.uff added"));
}

#[test]
fn csv_measurements_import_like_uff() {
    let ws = Workspace::new();
    ws.write(
        "m.csv",
        "# quantity: accelerance\nfrequency_hz,re:101+X/1-Z,im:101+X/1-Z\n10,1.5,-0.25\n10.5,1.25,-0.5\n",
    );
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  m:\n    kind: import\n    params: {path: m.csv}\n",
    );
    ws.run(&[], 0);
    let sets = artifact(&ws, "m");
    assert_eq!(sets[0].quantity, modalflow::frf::FrfQuantity::Accelerance);
    assert_eq!(
        sets[0].channels[0].values[1],
        num_complex::Complex64::new(1.25, -0.5)
    );
}

#[test]
fn bad_measurements_fail_the_stage_with_file_and_line() {
    let ws = Workspace::new();
    ws.write(
        "m.csv",
        "frequency_hz,re:101+X/1-Z,im:101+X/1-Z\n10,1.5,-0.25\n10.5,nan,-0.5\n",
    );
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  m:\n    kind: import\n    params: {path: m.csv}\n",
    );
    let r = ws.run(&[], 1);
    let err = r.stage("m")["error"].as_str().unwrap();
    assert!(err.contains("m.csv") && err.contains("line 3"), "{err}");
    assert_eq!(ws.runs_in_cache(), 0);
}

#[test]
fn import_params_are_validated_before_running() {
    let ws = Workspace::new();
    copy_fixture(&ws, "frf_58b_le.uff");
    let cases = [
        ("{path: 'nothing*.uff'}", "matches no file"),
        (
            "{path: frf_58b_le.uff, band: [30, 10]}",
            "band [30, 10] is empty",
        ),
        (
            "{path: frf_58b_le.uff, select: {responses: ['x1']}}",
            "DOF pattern",
        ),
        (
            "{path: frf_58b_le.uff, select: {function: psd}}",
            "cannot form an FRF artifact",
        ),
        (
            "{path: frf_58b_le.uff, format: hdf5}",
            "must be one of: uff, csv",
        ),
    ];
    for (params, needle) in cases {
        ws.write(
            "p.yaml",
            &format!("name: imp\nstages:\n  m:\n    kind: import\n    params: {params}\n"),
        );
        let out = ws.cmd(&["validate", "p.yaml"]);
        let stderr = util::text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{params}: {stderr}");
        assert!(
            stderr.contains(needle) && stderr.contains("p.yaml:5:"),
            "{params}: {stderr}"
        );
    }
}

#[test]
fn export_writes_what_other_tools_read() {
    let ws = Workspace::new();
    copy_fixture(&ws, "frf_58b_le.uff");
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  m:\n    kind: import\n    params: {path: frf_58b_le.uff}\n  ascii:\n    kind: export\n    inputs: {frf: m.frf}\n  table:\n    kind: export\n    inputs: {frf: m.frf}\n    params: {format: csv}\n",
    );
    ws.run(&[], 0);
    let original = artifact(&ws, "m");
    let text = std::fs::read(ws.path().join("results/imp/ascii/export/frf.uff")).unwrap();
    let file = modalflow::io::read_uff(&text, "frf.uff").unwrap();
    let back = modalflow::io::frf_sets_from_uff(&file, "frf.uff", &Default::default())
        .unwrap()
        .sets;
    assert_eq!(back[0].channels.len(), original[0].channels.len());
    for (a, b) in back[0].channels[0]
        .values
        .iter()
        .zip(&original[0].channels[0].values)
    {
        assert!(
            (a - b).norm() <= 1e-12 * b.norm(),
            "standard ASCII keeps 13 digits: {a} vs {b}"
        );
    }
    let csv = std::fs::read(ws.path().join("results/imp/table/export/frf.csv")).unwrap();
    let from_csv = modalflow::io::read_frf_csv(&csv, "frf.csv").unwrap();
    assert_eq!(from_csv[0].channels, original[0].channels, "CSV is exact");
}

/// An accelerance FRF written in g/N (as test software in the field does)
/// imports scaled by 9.80665 to m/s²/N, with a note in import.json; an
/// unknown unit label is an error naming the file and the record.
#[test]
fn uff_in_g_per_newton_imports_in_si_with_a_note() {
    use modalflow::frf::{Dof, FrfChannel, FrfQuantity, FrfSet};
    use modalflow::io::{uff58_from_frf_sets, write_uff58, NumberText, Storage, Uff58Format};
    use num_complex::Complex64;
    let si = FrfSet {
        quantity: FrfQuantity::Accelerance,
        frequencies_hz: (0..40).map(|i| 10.0 + 0.5 * i as f64).collect(),
        channels: vec![FrfChannel {
            response: Dof::new(101, 3),
            reference: Dof::new(1, -3),
            values: (0..40)
                .map(|i| Complex64::new(0.3 + 0.01 * i as f64, -0.2 + 0.003 * i as f64))
                .collect(),
            coherence: None,
        }],
        ..FrfSet::default()
    };
    let mut ds = uff58_from_frf_sets(std::slice::from_ref(&si));
    for d in &mut ds {
        d.ordinate_axis.units = "g".into();
        if let modalflow::io::Ordinate::Complex(v) = &mut d.ordinate {
            v.iter_mut().for_each(|x| *x /= 9.80665);
        }
    }
    let format = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::RoundTrip,
    };
    let ws = Workspace::new();
    std::fs::write(ws.path().join("g.uff"), write_uff58(&ds, &format)).unwrap();
    let mut bad = ds.clone();
    bad[0].ordinate_axis.units = "furlong".into();
    std::fs::write(ws.path().join("bad.uff"), write_uff58(&bad, &format)).unwrap();
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  g:\n    kind: import\n    params: {path: g.uff}\n",
    );
    ws.run(&[], 0);
    let got = artifact(&ws, "g");
    assert_eq!(got[0].quantity, FrfQuantity::Accelerance);
    for (a, b) in got[0].channels[0].values.iter().zip(&si.channels[0].values) {
        assert!((a - b).norm() <= 1e-15 * b.norm(), "{a} vs {b}");
    }
    let summary: serde_json::Value = ws.json("results/imp/g/import.json");
    let note = summary["units"][0].as_str().unwrap();
    assert!(
        note.contains("g.uff") && note.contains("g/N") && note.contains("9.80665"),
        "{note}"
    );
    assert_eq!(summary["quantity"], "accelerance");

    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  bad:\n    kind: import\n    params: {path: bad.uff}\n",
    );
    let out = ws.cmd(&["run", "p.yaml"]);
    assert_ne!(out.status.code(), Some(0));
    let err = util::text(&out.stderr);
    assert!(
        err.contains("bad.uff") && err.contains("record 9") && err.contains("furlong"),
        "{err}"
    );
}

/// Runs an import of `file` (already in `ws`) that must fail; its error.
fn import_error(ws: &Workspace, file: &str) -> String {
    ws.write(
        "p.yaml",
        &format!("name: imp\nstages:\n  m:\n    kind: import\n    params: {{path: {file}}}\n"),
    );
    let r = ws.run(&[], 1);
    r.stage("m")["error"].as_str().unwrap().to_string()
}

/// Impossible measurements are refused at import, naming the file and the
/// line of the value (they used to import silently, and `autoema` then
/// found "only 0 frequency lines"): negative and non-increasing
/// frequencies, coherence outside [0, 1], NaN.
#[test]
fn impossible_csv_measurements_are_refused_with_file_and_line() {
    let ws = Workspace::new();
    let head = "frequency_hz,re:101+X/1-Z,im:101+X/1-Z,coh:101+X/1-Z\n";
    let cases = [
        ("neg.csv", "0,1,0,0.5\n-5,1,0,0.5\n", "line 3", "negative"),
        (
            "flat.csv",
            "10,1,0,0.5\n10,1,0,0.5\n",
            "line 3",
            "does not increase",
        ),
        (
            "down.csv",
            "10,1,0,0.5\n11,1,0,0.5\n9,1,0,1\n",
            "line 4",
            "does not increase",
        ),
        (
            "coh.csv",
            "10,1,0,0.5\n11,1,0,7\n",
            "line 3",
            "coherence 7 is outside [0, 1]",
        ),
        ("cneg.csv", "10,1,0,-0.1\n", "line 2", "outside [0, 1]"),
        (
            "cnan.csv",
            "10,1,0,0.5\n11,1,0,NaN\n",
            "line 3",
            "not finite",
        ),
        (
            "fnan.csv",
            "10,1,0,0.5\nnan,1,0,0.5\n",
            "line 3",
            "not finite",
        ),
    ];
    for (file, rows, line, what) in cases {
        ws.write(file, &format!("{head}{rows}"));
        let err = import_error(&ws, file);
        assert!(
            err.contains(&format!("{file}, {line}")) && err.contains(what),
            "{file}: {err}"
        );
    }
    // Exactly 0 Hz and coherence 0 and 1 are fine.
    ws.write("ok.csv", &format!("{head}0,1,0,0\n0.5,1,0,1\n"));
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  m:\n    kind: import\n    params: {path: ok.csv}\n",
    );
    ws.run(&[], 0);
}

/// The same checks on universal files, at the line that holds the value:
/// record 7 for an evenly spaced axis starting below 0, the record 12 line
/// for an uneven axis that does not increase and for a coherence of 7.
#[test]
fn impossible_uff_measurements_are_refused_with_file_and_line() {
    use modalflow::frf::{Dof, FrfChannel, FrfSet};
    use modalflow::io::{uff58_from_frf_sets, write_uff58, NumberText, Storage, Uff58Format};
    use num_complex::Complex64;
    let set = |f: Vec<f64>, coherence: Option<Vec<f64>>| FrfSet {
        channels: vec![FrfChannel {
            response: Dof::new(101, 3),
            reference: Dof::new(1, -3),
            values: f.iter().map(|&x| Complex64::new(1.0, -x)).collect(),
            coherence,
        }],
        frequencies_hz: f,
        ..FrfSet::default()
    };
    let ascii = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::Standard,
    };
    let ws = Workspace::new();
    let cases = [
        // Even spacing from -1 Hz: record 7 (line 9) holds the minimum.
        (
            "neg.uff",
            set(vec![-1.0, -0.5, 0.0, 0.5], None),
            "-1.00000E+00",
            "negative",
        ),
        // Uneven, the third line equal to the second.
        (
            "flat.uff",
            set(vec![10.0, 11.0, 11.0, 12.5], None),
            "1.10000E+01",
            "does not increase",
        ),
        (
            "coh.uff",
            set(vec![10.0, 11.0, 12.0], Some(vec![0.9, 7.0, 0.9])),
            "7.000000000000E+00",
            "coherence 7 is outside [0, 1]",
        ),
    ];
    for (file, s, token, what) in cases {
        let text = write_uff58(&uff58_from_frf_sets(std::slice::from_ref(&s)), &ascii);
        std::fs::write(ws.path().join(file), &text).unwrap();
        let err = import_error(&ws, file);
        let line: usize = err
            .split(&format!("{file}, line "))
            .nth(1)
            .and_then(|r| r.split(':').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{file}: no line in {err}"));
        let held = String::from_utf8_lossy(&text)
            .lines()
            .nth(line - 1)
            .unwrap_or("")
            .to_string();
        assert!(err.contains(what), "{file}: {err}");
        assert!(
            held.contains(token),
            "{file}: line {line} is {held:?}, not the bad value {token}: {err}"
        );
    }
}

/// A CSV of 50,000 channels (150,001 columns) reads every channel with its
/// values and coherence, and writes back identically. The header used to be
/// matched column by column (quadratic: a 200,000-channel file took 7 min
/// to import); it is hashed now (3.7 s including the artifact, measured by
/// hand). No timing is asserted here.
#[test]
fn a_csv_of_fifty_thousand_channels_reads_every_channel() {
    use modalflow::frf::Dof;
    use modalflow::io::{read_frf_csv, write_frf_csv};
    let n = 50_000u32;
    let mut text = String::from("# quantity: mobility\nfrequency_hz");
    for k in 1..=n {
        text.push_str(&format!(",re:{k}+X/1-Z,im:{k}+X/1-Z,coh:{k}+X/1-Z"));
    }
    text.push('\n');
    for f in [0u32, 5, 10] {
        text.push_str(&f.to_string());
        for k in 1..=n {
            text.push_str(&format!(",{k},{f},0.{}", k % 10));
        }
        text.push('\n');
    }
    let sets = read_frf_csv(text.as_bytes(), "wide.csv").unwrap();
    assert_eq!(sets.len(), 1);
    let s = &sets[0];
    assert_eq!(s.frequencies_hz, vec![0.0, 5.0, 10.0]);
    assert_eq!(s.channels.len(), n as usize);
    for k in [1u32, 2, 25_000, n] {
        let c = &s.channels[k as usize - 1];
        assert_eq!((c.response, c.reference), (Dof::new(k, 1), Dof::new(1, -3)));
        assert_eq!(c.values[2], num_complex::Complex64::new(f64::from(k), 10.0));
        let coh = f64::from(k % 10) / 10.0;
        assert_eq!(c.coherence.as_deref(), Some(&[coh, coh, coh][..]));
    }
    let back = read_frf_csv(&write_frf_csv(&sets).unwrap(), "back.csv").unwrap();
    assert_eq!(back, sets);
}

/// Record 7's point count is checked against the memory limit before the
/// values are allocated: a 1 KiB limit refuses the 40-point fixture at
/// record 7, naming the estimate and the limit.
#[test]
fn a_point_count_over_the_memory_limit_is_refused_at_record_7() {
    let ws = Workspace::new();
    copy_fixture(&ws, "frf_58b_le.uff");
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  m:\n    kind: import\n    params: {path: frf_58b_le.uff}\n",
    );
    let r = ws.run(&["--max-memory", "1K"], 1);
    let err = r.stage("m")["error"].as_str().unwrap();
    assert!(
        err.contains("frf_58b_le.uff, line 9")
            && err.contains("40 points")
            && err.contains("memory limit of 1.0 KiB"),
        "{err}"
    );
}

/// The `geometry` output is the test geometry (nodes 2411, trace lines 82)
/// of the first universal file that has one, taken from the parse that
/// reads its FRFs: the Polytec PSV line scan (10 points, 10 trace lines)
/// before the surface scan (25 points) in a glob of both.
#[test]
fn geometry_comes_from_the_first_universal_file_with_nodes() {
    let ws = Workspace::new();
    for f in ["line_h2_accelerance.unv", "surface_h1_receptance.unv"] {
        ws.copy_in(&format!("benchmarks/real_sets/pycfs_psv/{f}"), f);
    }
    ws.write(
        "p.yaml",
        "name: imp\nstages:\n  psv: {kind: import, params: {path: \"*.unv\"}}\n",
    );
    ws.run(&[], 0);
    let g: serde_json::Value = ws.json("results/imp/psv/geometry.json");
    assert_eq!(g["nodes"].as_array().map(Vec::len), Some(10), "{g}");
    assert_eq!(g["lines"].as_array().map(Vec::len), Some(10), "{g}");
    assert_eq!(artifact(&ws, "psv").len(), 2, "one position per file");
}

/// `geometry:` names a universal file of its own (test software often
/// exports the geometry apart from the FRFs): the bridge's `coords.unv`,
/// 26 nodes and 37 trace segments (12 along each girder, 13 cross
/// members), replaces whatever the FRF file holds, and its skipped
/// datasets are warned about; a file without nodes is an error naming it.
#[test]
fn geometry_comes_from_the_file_the_param_names() {
    let ws = Workspace::new();
    for f in ["dam0.unv", "coords.unv", "literature_modes.csv"] {
        ws.copy_in(&format!("benchmarks/real_sets/cermelj_dam0/{f}"), f);
    }
    // Reference modes (`content: modes`) take the param too.
    let pipeline = |geometry: &str| {
        format!(
            "name: imp\nstages:\n  b: {{kind: import, params: {{path: dam0.unv, geometry: {geometry}, calibrated: false}}}}\n  lit: {{kind: import, params: {{path: literature_modes.csv, content: modes, geometry: {geometry}}}}}\n"
        )
    };
    ws.write("p.yaml", &pipeline("coords.unv"));
    let r0 = ws.run(&[], 0);
    let g: serde_json::Value = ws.json("results/imp/b/geometry.json");
    assert_eq!(g["nodes"].as_array().map(Vec::len), Some(26), "{g}");
    assert_eq!(g["lines"].as_array().map(Vec::len), Some(37), "{g}");
    let node = |id: u64| {
        g["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|n| n["id"] == id)
            .map(|n| n["xyz"].clone())
    };
    assert_eq!(node(113), Some(serde_json::json!([0.0, 360.0, 5080.0])));
    let lit: serde_json::Value = ws.json("results/imp/lit/geometry.json");
    assert_eq!(lit, g);
    let warnings = r0.stage("b")["warnings"].to_string();
    assert!(
        warnings.contains("coords.unv") && warnings.contains("734"),
        "{warnings}"
    );
    // A file without nodes: the FRF file itself.
    ws.write("p.yaml", &pipeline("dam0.unv"));
    let r = ws.run(&[], 1);
    let err = r.stage("b")["error"].as_str().unwrap();
    assert!(
        err.contains("dam0.unv") && err.contains("no node coordinates"),
        "{err}"
    );
}
