//! The quickstart pipeline end to end (the README's first command), in a
//! temp copy: every stage runs, the report is self-contained, and a rerun
//! is fully cached.

use crate::util;

use util::study;

#[test]
fn quickstart_runs_reports_and_caches() {
    let ws = study("quickstart", &[]);
    let r = ws.run(&[], 0);
    assert!(r.all("ran"), "{:?}", r.statuses());
    let html = ws.read("results/quickstart/report/report/index.html");
    assert!(html.contains("<h1>Quickstart — three-mass system</h1>"));
    assert!(html.contains("<td>score[measurement=hammer]</td>"));
    assert!(html.matches("<svg").count() >= 2, "figures inlined");
    // Stabilization diagrams, MAC matrices, FRF overlays and mode shapes.
    assert!(util::assert_report_figures(&ws, "quickstart") >= 8);
    assert!(
        !html.contains("src=\"") && !html.contains("<link"),
        "self-contained"
    );
    let md = ws.read("results/quickstart/report/report/report.md");
    for line in md.lines().filter(|l| l.starts_with("![")) {
        let file = line.split("](").nth(1).unwrap().trim_end_matches(')');
        assert!(
            ws.path()
                .join("results/quickstart/report/report")
                .join(file)
                .exists(),
            "{file}"
        );
    }
    // The noisy measurement scores FRAC < 1 but close to it.
    let m: serde_json::Value = ws.json("results/quickstart/score[measurement=noisy]/metrics.json");
    let frac = m["frf"]["mean_frac"].as_f64().unwrap();
    assert!(frac > 0.99 && frac < 1.0, "{frac}");
    // AutoEMA finds all three modes of each measurement.
    for which in ["noisy", "hammer"] {
        let m: serde_json::Value = ws.json(&format!(
            "results/quickstart/score[measurement={which}]/metrics.json"
        ));
        assert_eq!(m["modes"]["paired"], 3, "{which}: {m}");
        assert!(
            m["modes"]["mean_mac"].as_f64().unwrap() > 0.99,
            "{which}: {m}"
        );
        assert!(
            m["modes"]["mean_nfd"].as_f64().unwrap() < 0.01,
            "{which}: {m}"
        );
    }
    assert!(ws.run(&[], 0).all("cached"));

    // `compare` tabulates the matrix expansions' metrics.
    let out = ws.cmd(&["compare", "p.yaml", "score", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", util::text(&out.stderr));
    let table: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = table["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["matrix"]["measurement"], "hammer");
    assert_eq!(rows[0]["metrics"]["frf.mean_frac"].as_f64().unwrap(), frac);
    let csv = util::text(&ws.cmd(&["compare", "p.yaml", "--csv"]).stdout);
    assert!(csv.starts_with("stage,measurement,"), "{csv}");
}
