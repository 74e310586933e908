//! The `autoema` stage through the CLI: an `frf` artifact of a known 4-mode
//! system is imported and analysed; the modes, poles, fitted FRFs,
//! stabilization diagram and metrics land in the results directory.

use crate::util;

use modalflow::ema::synthetic::{four_mode_system, lines, modal_superposition};
use modalflow::io::{read_frf_artifact, write_frf_artifact};
use util::Workspace;

const PIPELINE: &str = "name: ema\nseed: 3\nstages:\n  measured:\n    kind: import\n    params: {path: truth.uff}\n  ema:\n    kind: autoema\n    inputs: {frf: measured.frf}\n    params: {band: [20, 260], max_order: [8, 24], iterations: 24, initial: 10, fixed: {max_damping: 0.1}}\n";

#[test]
fn autoema_identifies_the_modes_of_a_synthetic_system() {
    let ws = Workspace::new();
    let modes = four_mode_system();
    let set = modal_superposition(&modes, &[0, 3], &lines(10.0, 270.0, 0.25), 0.005, 5);
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    ws.write("p.yaml", PIPELINE);
    let report = ws.run(&[], 0);
    let stage = report.stage("ema");
    assert_eq!(stage["status"], "ran");
    assert_eq!(stage["counters"]["bo_iterations"], 24);
    assert_eq!(stage["counters"]["orders"], 24);

    let csv = ws.read("results/ema/ema/modes/modes.csv");
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (fc, zc) = (col("frequency_hz"), col("damping_ratio"));
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), modes.len(), "modes.csv:\n{csv}");
    for (row, m) in rows.iter().zip(&modes) {
        let f: f64 = row[fc].parse().unwrap();
        let z: f64 = row[zc].parse().unwrap();
        assert!(
            (f - m.frequency_hz).abs() / m.frequency_hz < 5e-3,
            "{f} vs {}",
            m.frequency_hz
        );
        assert!(
            (z - m.damping_ratio).abs() / m.damping_ratio < 0.1,
            "{z} vs {}",
            m.damping_ratio
        );
    }
    assert!(
        ws.read("results/ema/ema/modes/mode_shapes.csv")
            .lines()
            .count()
            > 1
    );

    let metrics: serde_json::Value = ws.json("results/ema/ema/metrics.json");
    assert!(metrics["mean_frac"].as_f64().unwrap() > 0.99, "{metrics}");
    assert_eq!(metrics["n_modes"], 4);
    assert_eq!(
        metrics["positions"][0]["trace"].as_array().unwrap().len(),
        24
    );
    assert_eq!(
        metrics["positions"][0]["hyperparameters"]["max_damping"],
        0.1
    );

    let poles = ws.read("results/ema/ema/poles.csv");
    assert!(poles.starts_with("position,order,frequency_hz,damping_ratio,"));
    let selected = poles
        .lines()
        .skip(1)
        .filter(|l| l.ends_with(",true"))
        .count();
    assert_eq!(selected, 4);

    let fit = read_frf_artifact(
        &std::fs::read(ws.path().join("results/ema/ema/frf_fit.uff")).unwrap(),
        "frf_fit.uff",
    )
    .unwrap();
    assert_eq!(fit[0].channels.len(), 10);
    assert!(fit[0]
        .frequencies_hz
        .iter()
        .all(|f| (20.0..=260.0).contains(f)));

    let svg = ws.read("results/ema/ema/stabilization.svg");
    assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("Model order") && svg.contains("Frequency [Hz]"));

    // A rerun is cached.
    assert_eq!(ws.run(&[], 0).status_of("ema"), "cached");
}

#[test]
fn bad_autoema_params_are_reported_before_anything_runs() {
    let ws = Workspace::new();
    let set = modal_superposition(&four_mode_system(), &[0], &lines(10.0, 100.0, 1.0), 0.0, 1);
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    ws.write(
        "p.yaml",
        &PIPELINE.replace("max_damping: 0.1", "max_dampin: 0.1"),
    );
    let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
    assert_eq!(out.status.code(), Some(2));
    let err = util::text(&out.stderr);
    assert!(
        err.contains("max_dampin") && err.contains("max_damping"),
        "{err}"
    );
}

#[test]
fn positions_are_analysed_separately() {
    let ws = Workspace::new();
    let modes = four_mode_system();
    let stiffer: Vec<_> = modes
        .iter()
        .map(|m| modalflow::ema::synthetic::SyntheticMode {
            frequency_hz: 1.05 * m.frequency_hz,
            ..m.clone()
        })
        .collect();
    let grid = lines(10.0, 270.0, 0.5);
    let mut sets = vec![
        modal_superposition(&modes, &[0, 3], &grid, 0.005, 1),
        modal_superposition(&stiffer, &[0, 3], &grid, 0.005, 2),
    ];
    sets[1].position = modalflow::frf::Position {
        index: 1,
        label: "stiff".into(),
    };
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&sets)).unwrap();
    ws.write(
        "p.yaml",
        &PIPELINE.replace("iterations: 24", "iterations: 16"),
    );
    let report = ws.run(&[], 0);
    assert_eq!(report.stage("ema")["counters"]["bo_iterations"], 32);
    let csv = ws.read("results/ema/ema/modes/modes.csv");
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (pc, fc) = (col("position"), col("frequency_hz"));
    for (pos, truth) in [(0, &modes), (1, &stiffer)] {
        let found: Vec<f64> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|r| r[pc] == pos.to_string())
            .map(|r| r[fc].parse().unwrap())
            .collect();
        assert_eq!(found.len(), 4, "position {pos}:\n{csv}");
        for (f, m) in found.iter().zip(truth.iter()) {
            assert!(
                (f - m.frequency_hz).abs() / m.frequency_hz < 5e-3,
                "position {pos}: {f} vs {}",
                m.frequency_hz
            );
        }
    }
}

/// Issue 14, CI-sized: members of the synthetic families with default
/// settings (only the band, from the data) — every visible mode found
/// (NFD < 0.5 %, NDD < 20 %, MAC ≥ 0.9; the span of a repeated root), no
/// spurious or duplicate mode, mean FRAC ≥ 1/(1 + r²) − 0.001. The success
/// rates over many seeds are measured by `cargo bench --bench polymax --
/// families` (README).
#[test]
fn synthetic_families_with_default_settings() {
    use modalflow::ema::families::{case, estimates, frf_data, score};
    use modalflow::ema::{auto_ema, AutoEmaParams};
    for (family, noise, seed) in [
        ("close_pair", 0.02, 1),
        ("close_pair", 0.05, 2),
        ("repeated_root", 0.02, 1),
        ("high_damping", 0.02, 2),
        // Noise ∝ |H|: each member made a strong mode a "repeated root"
        // before the multiplicity test scaled the residue separably.
        ("wide_band", 0.02, 11),
        ("wide_band", 0.02, 12),
    ] {
        let c = case(family, seed).unwrap();
        let d = frf_data(&c, noise, seed);
        let r = auto_ema(&d, &AutoEmaParams::default(), &|| {}).unwrap();
        let s = score(&c, noise, &estimates(&r), r.best.mean_frac);
        assert!(
            s.success,
            "{family} at {noise}, seed {seed}: {s:?}, FRAC {}",
            r.best.mean_frac
        );
        if family == "repeated_root" {
            let doubles = r.best.roots.iter().filter(|x| x.multiplicity == 2).count();
            assert_eq!(doubles, 2, "both repeated roots hold two modes");
        }
    }
}

/// metrics.json states per position what validation rejected and why, the
/// search box and any bound the result sits on, the noise floor, residual
/// structure and whether the goal was reached; poles.csv has the classes;
/// the diagram draws them with the CMIF curves.
#[test]
fn autoema_outputs_say_what_was_decided() {
    let ws = Workspace::new();
    let c = modalflow::ema::families::case("close_pair", 3).unwrap();
    let mut set = modal_superposition(&c.modes, &c.references, &c.frequencies_hz, 0.02, 3);
    set.position = modalflow::frf::Position {
        index: 0,
        label: "p".into(),
    };
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    ws.write(
        "p.yaml",
        "name: ema\nseed: 3\nstages:\n  measured:\n    kind: import\n    params: {path: truth.uff}\n  ema:\n    kind: autoema\n    inputs: {frf: measured.frf}\n    params: {band: [20, 260]}\n",
    );
    ws.run(&[], 0);
    let m: serde_json::Value = ws.json("results/ema/ema/metrics.json");
    let p = &m["positions"][0];
    assert_eq!(m["n_modes"], 6, "{m}");
    assert!(m["goal_reached"].is_boolean() && p["goal_reached"].is_boolean());
    for key in [
        "rejected",
        "at_bound",
        "residual_peaks",
        "warnings",
        "modes",
        "trace",
    ] {
        assert!(p[key].is_array(), "{key}: {p}");
    }
    assert!(p["noise"]["median_relative"].as_f64().unwrap() > 0.01);
    assert!(p["noise"]["median_relative"].as_f64().unwrap() < 0.04);
    assert!(
        p["bounds"]["max_order"][1].as_f64().unwrap()
            > p["bounds"]["max_order"][0].as_f64().unwrap()
    );
    assert!(p["data"]["cmif_peaks"].as_u64().unwrap() >= 5);
    // Every rejection says why.
    for r in p["rejected"].as_array().unwrap() {
        assert!(
            r["reason"].is_string() && r["frequency_hz"].is_number(),
            "{r}"
        );
    }
    // A bound beyond which a better-fitting selection lacks modes of the
    // result is a warning naming it and those modes; the others are listed.
    let warned = m["warnings"].as_array().unwrap();
    for b in p["at_bound"].as_array().unwrap() {
        let lacks = b["only_here_hz"].as_array().unwrap();
        assert_eq!(b["sensitive"] == true, !lacks.is_empty(), "{b}");
        if lacks.is_empty() {
            continue;
        }
        let name = format!("`{}` beyond", b["name"].as_str().unwrap());
        let hz = format!("{:.2}", lacks[0].as_f64().unwrap());
        assert!(
            warned.iter().any(|w| {
                let w = w.as_str().unwrap();
                w.contains(&name) && w.contains(&hz)
            }),
            "{b}"
        );
    }
    let poles = ws.read("results/ema/ema/poles.csv");
    assert!(poles
        .lines()
        .next()
        .unwrap()
        .contains(",class,cluster,root,selected"));
    let svg = ws.read("results/ema/ema/stabilization.svg");
    for needle in [
        "CMIF σ1",
        "CMIF σ2",
        "stable f, ζ, vector",
        "selected mode",
        "rejected root",
    ] {
        assert!(svg.contains(needle), "{needle}");
    }
}

/// Rows of modes.csv: (frequency, damping) per mode.
pub(crate) fn modes_csv(ws: &Workspace, stage: &str) -> Vec<(f64, f64)> {
    let csv = ws.read(&format!("results/ema/{stage}/modes/modes.csv"));
    csv.lines()
        .skip(1)
        .map(|l| {
            // position,position_label,mode,frequency_hz,damping_ratio
            let r: Vec<&str> = l.split(',').collect();
            (r[3].parse().unwrap(), r[4].parse().unwrap())
        })
        .collect()
}

/// Shapes of mode_shapes.csv: per mode, (node, direction) → complex value.
pub(crate) fn shapes_csv(
    ws: &Workspace,
    stage: &str,
) -> Vec<std::collections::BTreeMap<(u32, String), num_complex::Complex64>> {
    let csv = ws.read(&format!("results/ema/{stage}/modes/mode_shapes.csv"));
    let mut out: Vec<std::collections::BTreeMap<_, _>> = Vec::new();
    for l in csv.lines().skip(1) {
        let r: Vec<&str> = l.split(',').collect();
        // position,mode,node,direction,real,imag
        let m: usize = r[1].parse().unwrap();
        if out.len() < m {
            out.resize(m, Default::default());
        }
        out[m - 1].insert(
            (r[2].parse().unwrap(), r[3].to_string()),
            num_complex::Complex64::new(r[4].parse().unwrap(), r[5].parse().unwrap()),
        );
    }
    out
}

fn shape_mac(
    a: &std::collections::BTreeMap<(u32, String), num_complex::Complex64>,
    b: &std::collections::BTreeMap<(u32, String), num_complex::Complex64>,
) -> f64 {
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    let dot: num_complex::Complex64 = a.values().zip(b.values()).map(|(x, y)| x.conj() * y).sum();
    let n = |v: &std::collections::BTreeMap<_, num_complex::Complex64>| {
        v.values().map(|x| x.norm_sqr()).sum::<f64>()
    };
    dot.norm_sqr() / (n(a) * n(b))
}

/// A roving-hammer test (5 references × 1 response) gives the modes of the
/// roving-accelerometer test it mirrors by reciprocity: same frequencies,
/// damping and shapes (now at the hammer DOFs), the layout stated in
/// metrics.json and modes/layout.json, the fitted FRFs as measured;
/// `reciprocity: never` fits the 1 × 5 matrix as before.
#[test]
fn roving_hammer_layout_gives_the_modes_of_its_transpose() {
    let ws = Workspace::new();
    let modes = four_mode_system();
    let shaker = modal_superposition(&modes, &[2], &lines(10.0, 270.0, 0.25), 0.005, 7);
    let mut hammer = shaker.clone();
    for c in &mut hammer.channels {
        std::mem::swap(&mut c.response, &mut c.reference);
    }
    std::fs::write(ws.path().join("hammer.uff"), write_frf_artifact(&[hammer])).unwrap();
    std::fs::write(ws.path().join("shaker.uff"), write_frf_artifact(&[shaker])).unwrap();
    let params = "band: [20, 260], max_order: [8, 24], iterations: 24, initial: 10, fixed: {max_damping: 0.1}";
    ws.write(
        "p.yaml",
        &format!(
            "name: ema\nstages:\n  h: {{kind: import, params: {{path: hammer.uff}}}}\n  s: {{kind: import, params: {{path: shaker.uff}}}}\n  \
             hammer: {{kind: autoema, inputs: {{frf: h.frf}}, params: {{{params}}}}}\n  \
             shaker: {{kind: autoema, inputs: {{frf: s.frf}}, params: {{{params}}}}}\n  \
             never: {{kind: autoema, inputs: {{frf: h.frf}}, params: {{{params}, reciprocity: never}}}}\n"
        ),
    );
    let report = ws.run(&[], 0);
    assert_eq!(
        report.stage("hammer")["counters"]["transposed_positions"],
        1
    );
    assert_eq!(
        report.stage("shaker")["counters"]["transposed_positions"],
        0
    );
    let metrics = |stage: &str| -> serde_json::Value {
        ws.json(&format!("results/ema/{stage}/metrics.json"))
    };
    assert_eq!(
        metrics("hammer")["layout"],
        "transposed by reciprocity (5 references × 1 response fitted as 5 outputs × 1 reference)"
    );
    assert_eq!(
        metrics("shaker")["layout"],
        "as measured (1 reference × 5 responses fitted as 5 outputs × 1 reference)"
    );
    assert_eq!(
        metrics("never")["layout"],
        "as measured (5 references × 1 response fitted as 1 output × 5 references)"
    );
    let layout: serde_json::Value = ws.json("results/ema/hammer/modes/layout.json");
    assert_eq!(layout["positions"][0]["transposed"], true);
    assert_eq!(layout["positions"][0]["shape_dofs"], "measured references");

    let (h, s) = (modes_csv(&ws, "hammer"), modes_csv(&ws, "shaker"));
    assert_eq!(h.len(), modes.len(), "{h:?}");
    assert_eq!(h.len(), s.len());
    for ((fh, zh), ((fs, zs), m)) in h.iter().zip(s.iter().zip(&modes)) {
        assert!((fh - fs).abs() <= 1e-9 * fs && (zh - zs).abs() <= 1e-9 * zs);
        assert!((fh - m.frequency_hz).abs() < 5e-3 * m.frequency_hz);
        assert!((zh - m.damping_ratio).abs() < 0.1 * m.damping_ratio);
    }
    let (sh, ss) = (shapes_csv(&ws, "hammer"), shapes_csv(&ws, "shaker"));
    for (a, b) in sh.iter().zip(&ss) {
        assert_eq!(a.len(), 5, "shapes at the five hammer DOFs");
        assert!(shape_mac(a, b) > 0.9999);
    }
    // The fitted FRFs keep the measured orientation.
    let fit = read_frf_artifact(
        &std::fs::read(ws.path().join("results/ema/hammer/frf_fit.uff")).unwrap(),
        "frf_fit.uff",
    )
    .unwrap();
    assert_eq!(fit[0].responses().len(), 1);
    assert_eq!(fit[0].references().len(), 5);

    // never: one output, five references; the shapes at the one response.
    // The 1 × 5 matrix has rank one: one CMIF curve, the same peaks as the
    // transpose's (the four further curves of round-off once counted
    // hundreds), and the same four modes.
    let n = modes_csv(&ws, "never");
    assert!(shapes_csv(&ws, "never").iter().all(|m| m.len() == 1));
    let peaks = |stage: &str| metrics(stage)["positions"][0]["data"]["cmif_peaks"].clone();
    assert_eq!(peaks("never"), peaks("hammer"));
    assert_eq!(n.len(), modes.len(), "{n:?}");
    for ((f, _), m) in n.iter().zip(&modes) {
        assert!((f - m.frequency_hz).abs() < 5e-3 * m.frequency_hz, "{n:?}");
    }
}

/// Partial matrices: a missing channel whose reciprocal was measured is
/// taken from it; a response missing a channel both ways is left out (the
/// largest complete sub-matrix), with warnings naming both; a matrix where
/// less than half the channels would remain is refused, naming them.
#[test]
fn partial_matrices_are_completed_by_reciprocity_or_reduced() {
    use modalflow::ema::synthetic::dof;
    let ws = Workspace::new();
    let mut set = modal_superposition(
        &four_mode_system(),
        &[0, 3],
        &lines(10.0, 270.0, 0.25),
        0.005,
        5,
    );
    set.channels.retain(|c| {
        let k = (c.response, c.reference);
        k != (dof(0), dof(3)) && k != (dof(4), dof(3))
    });
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    ws.write("p.yaml", PIPELINE);
    ws.run(&[], 0);
    let m: serde_json::Value = ws.json("results/ema/ema/metrics.json");
    let layout = &m["positions"][0]["layout"];
    assert_eq!(
        layout["filled_by_reciprocity"],
        serde_json::json!(["1+Z/4+Z"])
    );
    assert_eq!(layout["missing"], serde_json::json!(["5+Z/4+Z"]));
    assert_eq!(layout["dropped_responses"], serde_json::json!(["5+Z"]));
    let warnings = m["warnings"].to_string();
    assert!(
        warnings.contains("reciprocal") && warnings.contains("5+Z/4+Z"),
        "{warnings}"
    );
    assert_eq!(modes_csv(&ws, "ema").len(), 4);
    assert!(shapes_csv(&ws, "ema").iter().all(|s| s.len() == 4));

    // Every reference at two responses of its own (no reciprocal filling
    // with `never`): at most 2 of the 6 channels are complete, refused.
    let mut set = modal_superposition(
        &four_mode_system(),
        &[0, 2, 4],
        &lines(10.0, 270.0, 0.25),
        0.0,
        1,
    );
    let pairs = [(0, 0), (1, 0), (2, 2), (3, 2), (4, 4), (0, 4)];
    set.channels.retain(|c| {
        pairs
            .iter()
            .any(|&(r, q)| (c.response, c.reference) == (dof(r), dof(q)))
    });
    std::fs::write(ws.path().join("truth.uff"), write_frf_artifact(&[set])).unwrap();
    ws.write(
        "p.yaml",
        &PIPELINE.replace(
            "fixed: {max_damping: 0.1}}",
            "fixed: {max_damping: 0.1}, reciprocity: never}",
        ),
    );
    let out = ws.cmd(&["run", "p.yaml", "--progress", "none"]);
    assert_ne!(out.status.code(), Some(0));
    let err = format!("{}{}", util::text(&out.stdout), util::text(&out.stderr));
    assert!(err.contains("missing") && err.contains("`select`"), "{err}");
}
