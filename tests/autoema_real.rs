//! The `autoema` stage on measured FRFs (issue 31): the UFSC beam of
//! `../shared/data/real` (skipped when it is not there) and the MIT sets of
//! `benchmarks/real_sets` — seed invariance, few and true warnings, and no
//! stable column that vanishes without trace.

use crate::autoema::{modes_csv, shapes_csv};
use crate::util::{self, Workspace};

/// The real beam's roving-hammer test (../shared, linked as `data/`)
/// imported as stage `beam` on [5, `top`] Hz with `stages` after it, run;
/// None when ../shared is absent outside CI ([`util::real_beam_dir`]).
fn hammer_test(top: f64, stages: &str) -> Option<Workspace> {
    beam_test("frf_hammer_as_measured.uff", top, stages)
}

/// [`hammer_test`] for any of the beam's files.
fn beam_test(file: &str, top: f64, stages: &str) -> Option<Workspace> {
    let dir = util::real_beam_dir()?;
    let ws = Workspace::new();
    std::os::unix::fs::symlink(&dir, ws.path().join("data")).unwrap();
    ws.write(
        "p.yaml",
        &format!(
            "name: ema\nread_outside: [{}]\nstages:\n  beam: {{kind: import, params: {{path: data/{file}, band: [5, {top}]}}}}\n{stages}",
            dir.display()
        ),
    );
    ws.run(&[], 0);
    Some(ws)
}

/// The real beam (tests data of ../shared), roving hammer as measured, on a
/// narrow band with few iterations: the modes do not depend on the seed.
#[test]
fn real_beam_modes_do_not_depend_on_the_seed() {
    let stages: String = (1..=4)
        .map(|seed| {
            format!(
                "  s{seed}: {{kind: autoema, inputs: {{frf: beam.frf}}, params: {{seed: {seed}, iterations: 12, initial: 6}}}}\n"
            )
        })
        .collect();
    let Some(ws) = hammer_test(180.0, &stages) else {
        return;
    };
    let first = modes_csv(&ws, "s1");
    assert!(first.len() >= 3, "{first:?}");
    for (f, want) in [17.2, 68.8, 155.4].iter().zip([0.02, 0.02, 0.01]) {
        assert!(
            first.iter().any(|(x, _)| (x - f).abs() <= want * f),
            "no mode near {f} Hz: {first:?}"
        );
    }
    for seed in 2..=4 {
        let other = modes_csv(&ws, &format!("s{seed}"));
        assert_eq!(
            other.len(),
            first.len(),
            "seed {seed}: {other:?} vs {first:?}"
        );
        for ((a, _), (b, _)) in other.iter().zip(&first) {
            assert!(
                (a - b).abs() <= 1e-3 * b,
                "seed {seed}: {other:?} vs {first:?}"
            );
        }
    }
    let m: serde_json::Value = ws.json("results/ema/s1/metrics.json");
    assert_eq!(
        m["layout"],
        "transposed by reciprocity (30 references × 1 response fitted as 30 outputs × 1 reference)"
    );
}

/// The real beam's roving-hammer test on its full band with default
/// params: the published modes found, at most 3 warnings, and none that
/// calls a mode missing where one was identified (issue 31).
#[test]
fn real_beam_warnings_are_few_and_none_at_an_identified_mode() {
    let Some(ws) = hammer_test(
        800.0,
        "  full: {kind: autoema, inputs: {frf: beam.frf}, params: {band: [5, 800]}}\n",
    ) else {
        return;
    };
    let modes = modes_csv(&ws, "full");
    let published = [
        17.212, 68.840, 118.878, 155.391, 226.395, 235.230, 265.219, 362.805, 414.118, 567.539,
        602.292, 643.435, 707.200, 740.567,
    ];
    let found = published
        .iter()
        .filter(|f| modes.iter().any(|(x, _)| (x - *f).abs() <= 0.01 * *f))
        .count();
    assert!(found >= 12, "{found} of 14 published modes: {modes:?}");
    let m: serde_json::Value = ws.json("results/ema/full/metrics.json");
    let warnings: Vec<&str> = m["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert!(warnings.len() <= 3, "{warnings:#?}");
    for w in &warnings {
        let Some(at) = w.split("the data peak at ").nth(1) else {
            continue;
        };
        let f: f64 = at.split(" Hz").next().unwrap().parse().unwrap();
        // The window in which a data peak belongs to a mode: max(2 Δf, ζ f).
        let at_mode = modes
            .iter()
            .any(|(x, z)| (x - f).abs() <= (2.0f64).max(z * x));
        assert!(!at_mode, "{w} — a mode was identified there: {modes:?}");
    }
}

/// AutoEMA's metrics.json on vibration-toolbox case 1 (MIT, in the
/// repository), 10–490 Hz, default params.
fn case1_metrics() -> serde_json::Value {
    let ws = Workspace::new();
    ws.copy_in(
        "benchmarks/real_sets/vibration_toolbox_cases/case1.uff",
        "case1.uff",
    );
    ws.write(
        "p.yaml",
        "name: ema\nstages:\n  imp: {kind: import, params: {path: case1.uff, band: [10, 490], calibrated: false}}\n  ema: {kind: autoema, inputs: {frf: imp.frf}, params: {band: [10, 490]}}\n",
    );
    ws.run(&[], 0);
    let m: serde_json::Value = ws.json("results/ema/ema/metrics.json");
    m
}

/// Measured (vibration-toolbox case 1, MIT, `benchmarks/real_sets`): the
/// stable PolyMAX column at 162 Hz (orders 15–72, ζ ≈ 3.7 %) ends as a mode
/// or as a rejection with its reason, never without trace (issue 31).
#[test]
fn a_stable_column_ends_as_a_mode_or_a_rejection() {
    let m = case1_metrics();
    let pos = &m["positions"][0];
    let near = |v: &&serde_json::Value| (v["frequency_hz"].as_f64().unwrap() - 162.0).abs() <= 2.0;
    let modes: Vec<_> = pos["modes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(near)
        .collect();
    let rejected: Vec<_> = pos["rejected"]
        .as_array()
        .unwrap()
        .iter()
        .filter(near)
        .collect();
    let tall = |r: &&&serde_json::Value| r["n_orders"].as_u64().unwrap() >= 40;
    assert!(
        !modes.is_empty() || rejected.iter().any(|r| tall(&r) && r["reason"].is_string()),
        "162 Hz is neither a mode nor rejected: {rejected:?}"
    );
}

/// Measured (vibration-toolbox case 2, MIT): one resonance at 192.5 Hz with
/// ζ ≈ 0.03 %, a half-power band of 0.4 lines at 0.3125 Hz. The mode is
/// found, but no modal model reproduces lines that cannot show its peak
/// (mean FRAC 0.43): the result says so and names the mode, and the
/// finely resolved case 1 (FRAC 0.995) is not warned about (issue 31).
#[test]
fn a_fit_the_noise_does_not_explain_is_warned_about() {
    let ws = Workspace::new();
    let mut stages = String::from("name: ema\nstages:\n");
    for case in ["case1", "case2"] {
        ws.copy_in(
            &format!("benchmarks/real_sets/vibration_toolbox_cases/{case}.uff"),
            &format!("{case}.uff"),
        );
        stages.push_str(&format!(
            "  i{case}: {{kind: import, params: {{path: {case}.uff, band: [10, 490], calibrated: false}}}}\n  {case}: {{kind: autoema, inputs: {{frf: i{case}.frf}}, params: {{band: [10, 490]}}}}\n"
        ));
    }
    ws.write("p.yaml", &stages);
    ws.run(&[], 0);
    let poor = |case: &str| -> Vec<String> {
        let m: serde_json::Value = ws.json(&format!("results/ema/{case}/metrics.json"));
        m["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap().to_string())
            .filter(|w| w.contains("reproduce the FRFs poorly"))
            .collect()
    };
    let m: serde_json::Value = ws.json("results/ema/case2/metrics.json");
    let pos = &m["positions"][0];
    let mode = pos["modes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| (v["frequency_hz"].as_f64().unwrap() - 192.5).abs() <= 0.5)
        .expect("the 192.5 Hz mode");
    let lines = mode["bandwidth_lines"].as_f64().unwrap();
    assert!(lines > 0.1 && lines < 1.0, "{lines}");
    assert!(pos["mean_frac"].as_f64().unwrap() < 0.8, "{pos:?}");
    assert_eq!(m["goal_reached"], false);
    let w = poor("case2");
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("192.") && w[0].contains("narrower than one line"),
        "{w:?}"
    );
    assert!(poor("case1").is_empty(), "{:?}", poor("case1"));
}

/// The mode's entry of `metrics.json` position 0 within 1 Hz of `f_hz`,
/// among `modes` or `rejected`.
fn entry_near<'a>(
    pos: &'a serde_json::Value,
    list: &str,
    f_hz: f64,
) -> Option<&'a serde_json::Value> {
    pos[list]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| (v["frequency_hz"].as_f64().unwrap() - f_hz).abs() <= 1.0)
}

/// A mode kept for significance alone whose score does not exceed the
/// inflation of its ΔRSS by the residual's serial correlation is dropped
/// when fewer than half of the next-best selections hold it: the beam's
/// shaker test (../shared) at 628 Hz, between the published 602 and
/// 643 Hz modes, no peak of its own. Vibration-toolbox case 1's weak
/// 162.4 Hz mode (MIT, in the repository) has a score below its inflation
/// too, but 10 of 12 neighbours hold it, and it stays (issue 31, autoema 22).
#[test]
fn a_root_on_smooth_model_error_is_dropped_unless_its_neighbours_hold_it() {
    let m = case1_metrics();
    let pos = &m["positions"][0];
    let of = pos["consensus_of"].as_u64().unwrap();
    let weak = entry_near(pos, "modes", 162.4).expect("162.4 Hz kept");
    assert_eq!(weak["accepted_by"], "significance", "{weak}");
    let (score, inflation) = (
        weak["score"].as_f64().unwrap(),
        weak["serial_inflation"].as_f64().unwrap(),
    );
    assert!(score < inflation, "{weak}");
    assert!(2 * weak["support"].as_u64().unwrap() >= of, "{weak}");
    // The strong, lightly damped mode sits in a residual as good as white.
    let strong = entry_near(pos, "modes", 212.1).expect("212.1 Hz");
    assert!(
        strong["serial_inflation"].as_f64().unwrap() < 1.5,
        "{strong}"
    );

    let Some(ws) = beam_test(
        "frf_shaker.uff",
        1000.0,
        "  ema: {kind: autoema, inputs: {frf: beam.frf}, params: {band: [5, 1000]}}\n",
    ) else {
        return;
    };
    let m: serde_json::Value = ws.json("results/ema/ema/metrics.json");
    let pos = &m["positions"][0];
    assert!(entry_near(pos, "modes", 628.1).is_none(), "{pos}");
    let r = entry_near(pos, "rejected", 628.1).expect("628.1 Hz rejected");
    assert_eq!(r["reason"], "serial_correlation", "{r}");
    assert!(
        r["score"].as_f64().unwrap() < r["inflation"].as_f64().unwrap(),
        "{r}"
    );
    assert!(
        2 * r["support"].as_u64().unwrap() < r["of"].as_u64().unwrap(),
        "{r}"
    );
    for f in [602.3, 643.4] {
        let near = pos["modes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|v| (v["frequency_hz"].as_f64().unwrap() - f).abs() <= 0.02 * f);
        assert!(near, "no mode near {f} Hz");
    }
}

/// The I-40 bridge's six modes below 5 Hz as the literature gives them
/// (Farrar et al. 1994, LA-12767-MS; not checked against the report here,
/// `benchmarks/real_sets/cermelj_dam0/README.md`).
const BRIDGE_MODES_HZ: [f64; 6] = [2.48, 2.96, 3.50, 4.08, 4.17, 4.63];

/// Measured (dam0.unv, BSD-2-Clause, `benchmarks/real_sets/cermelj_dam0`):
/// 26 accelerances of a three-span two-girder bridge over one shaker, as
/// measured (1 × 26) and transposed (26 × 1, another seed), 1.5–5 Hz,
/// default params. Both give the six literature modes within 1 % (the
/// 4.08/4.17 Hz pair is three lines apart), nothing else, no warning, and
/// shapes a structural engineer recognises without the literature: still
/// at the four supports, the two girders in phase (bending) or in
/// opposition (torsion).
#[test]
fn a_bridge_gives_its_six_modes_in_both_layouts() {
    let ws = Workspace::new();
    ws.copy_in("benchmarks/real_sets/cermelj_dam0/dam0.unv", "dam0.unv");
    ws.copy_in(
        "benchmarks/real_sets/cermelj_dam0/frf_26x1.uff",
        "frf_26x1.uff",
    );
    let import =
        |file: &str| format!("{{kind: import, params: {{path: {file}, calibrated: false}}}}");
    let ema = |frf: &str, seed: u32| {
        format!("{{kind: autoema, inputs: {{frf: {frf}.frf}}, params: {{band: [1.5, 5.0], seed: {seed}}}}}")
    };
    ws.write(
        "p.yaml",
        &format!(
            "name: ema\nstages:\n  m: {}\n  t: {}\n  measured: {}\n  transposed: {}\n",
            import("dam0.unv"),
            import("frf_26x1.uff"),
            ema("m", 1),
            ema("t", 5)
        ),
    );
    ws.run(&[], 0);
    let measured = modes_csv(&ws, "measured");
    for stage in ["measured", "transposed"] {
        let modes = modes_csv(&ws, stage);
        assert_eq!(modes.len(), 6, "{stage}: {modes:?}");
        for ((f, _), want) in modes.iter().zip(BRIDGE_MODES_HZ) {
            assert!((f / want - 1.0).abs() < 0.01, "{stage}: {modes:?}");
        }
        for ((a, _), (b, _)) in modes.iter().zip(&measured) {
            assert!(
                (a / b - 1.0).abs() < 2e-3,
                "{stage}: {modes:?} vs {measured:?}"
            );
        }
        let m: serde_json::Value = ws.json(&format!("results/ema/{stage}/metrics.json"));
        assert_eq!(m["warnings"].as_array().unwrap().len(), 0, "{stage}: {m}");
        // Supports at points 1, 5, 9, 13 (101, …): |φ| there under a tenth
        // of the largest. South (1–13) · north (101–113): +1 bending, −1 torsion.
        for (k, (shape, bending)) in shapes_csv(&ws, stage)
            .iter()
            .zip([true, false, true, true, false, false])
            .enumerate()
        {
            let at = |n: u32| shape[&(n, "+X".to_string())];
            let peak = shape.values().map(|v| v.norm()).fold(0.0, f64::max);
            for n in [1, 5, 9, 13, 101, 105, 109, 113] {
                assert!(
                    at(n).norm() < 0.1 * peak,
                    "{stage} mode {}: node {n}",
                    k + 1
                );
            }
            let dot: num_complex::Complex64 = (1..=13).map(|n| at(n) * at(n + 100).conj()).sum();
            let norm = |o: u32| (1..=13).map(|n| at(n + o).norm_sqr()).sum::<f64>().sqrt();
            let corr = dot.re / (norm(0) * norm(100));
            assert!(
                if bending { corr > 0.9 } else { corr < -0.9 },
                "{stage} mode {}: south·north {corr}",
                k + 1
            );
        }
    }
    let m: serde_json::Value = ws.json("results/ema/transposed/metrics.json");
    assert!(
        m["layout"]
            .as_str()
            .unwrap()
            .starts_with("transposed by reciprocity"),
        "{}",
        m["layout"]
    );
}
