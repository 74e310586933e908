//! FE export formats (issue 16): the two-node fixture of
#![allow(non_snake_case)]
//! `tests/fixtures/fe/` (README there) in Matrix Market, Harwell–Boeing with
//! an ANSYS mapping, Abaqus coordinate `.mtx` and a Nastran DMIG punch gives
//! the same super-element, the analytic eigenvalues and nodes from the
//! files' labels; malformed copies fail naming the file, field and line.

use modalflow::dynamics::{Model, PreparedModel};
use std::path::Path;

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/fe")
}

fn model(superelement: &str, nodes: &str) -> String {
    format!(
        "parameters: []\nbodies:\n  - name: se\n    superelement:\n{superelement}\n      nodes:\n{nodes}\n      points: {{a: {{node: 20}}}}\nsensors: [{{name: s, body: se, point: a, node: 1, direction: 1}}]\nexcitations: [{{name: s, body: se, point: a, node: 1, direction: 1}}]\n"
    )
}

const LABELLED_NODES: &str =
    "        - {id: 10, position: [0, 0, 0]}\n        - {id: 20, position: [1, 0, 0]}";
const ROW_NODES: &str = "        - {id: 10, dofs: [0, 1, 2], position: [0, 0, 0]}\n        - {id: 20, dofs: [3, 4, 5], position: [1, 0, 0]}";

fn load(text: &str, dir: &Path) -> Result<Model, String> {
    let resolver = modalflow::dynamics::directory_resolver(dir);
    Model::from_yaml(text, "se.yaml", &resolver).map_err(|e| e.to_string())
}

fn cases() -> Vec<(&'static str, String)> {
    vec![
        (
            "matrix market",
            model("      mass: bench_m.mtx\n      stiffness: bench_k.mtx", ROW_NODES),
        ),
        (
            "harwell-boeing + mapping",
            model(
                "      mass: bench_mass.hb\n      stiffness: bench_stiff.hb\n      mapping: bench.mapping",
                LABELLED_NODES,
            ),
        ),
        (
            "harwell-boeing, rows given",
            model(
                "      mass: bench_mass.hb\n      stiffness: bench_stiff.hb\n      format: harwell_boeing",
                ROW_NODES,
            ),
        ),
        (
            "abaqus",
            model(
                "      mass: bench_MASS1.mtx\n      stiffness: bench_STIF1.mtx",
                LABELLED_NODES,
            ),
        ),
        (
            "nastran dmig",
            model(
                "      mass: bench.pch\n      stiffness: bench.pch\n      mass_matrix: MAAX\n      stiffness_matrix: KAAX",
                LABELLED_NODES,
            ),
        ),
    ]
}

#[test]
fn every_format_gives_the_analytic_modes_and_the_same_matrices() {
    let exact = {
        let r = (750.0f64.powi(2) + 500.0f64.powi(2)).sqrt();
        [1250.0 - r, 1250.0 + r]
    };
    let mut reference = None;
    for (name, text) in cases() {
        let m = load(&text, &fixtures()).unwrap_or_else(|e| panic!("{name}: {e}"));
        let p = PreparedModel::new(&m).unwrap();
        assert_eq!(p.n_dofs(), 6, "{name}");
        let [M, K, _, _] = p.matrices(0, &[]).unwrap();
        let sol = p.evaluate(0, &[], 6).unwrap();
        for (r, l) in sol.eigenvalues.iter().enumerate() {
            let want = exact[r / 3];
            assert!(
                (l - want).abs() < 1e-9 * want,
                "{name}: λ{r} = {l}, want {want}"
            );
        }
        // The sensor is node 20's x: its mode shapes must be node 20's rows.
        assert!(
            p.dof_labels[3].contains("node20.x"),
            "{name}: {:?}",
            p.dof_labels
        );
        match &reference {
            None => reference = Some((M, K)),
            Some((M0, K0)) => {
                assert!((&M - M0).norm_max() == 0.0, "{name}: mass differs");
                assert!((&K - K0).norm_max() == 0.0, "{name}: stiffness differs");
            }
        }
    }
}

/// Copy the fixtures with one file rewritten by `edit`.
fn broken(file: &str, edit: impl Fn(&str) -> String) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir(fixtures()).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
    }
    let text = std::fs::read_to_string(fixtures().join(file)).unwrap();
    std::fs::write(dir.path().join(file), edit(&text)).unwrap();
    dir
}

#[test]
fn malformed_files_fail_with_file_field_and_line() {
    let c = cases();
    let text = |name: &str| c.iter().find(|(n, _)| *n == name).unwrap().1.clone();
    // Harwell–Boeing: a value that is not a number on line 7.
    let d = broken("bench_stiff.hb", |t| {
        t.replacen("-1.000000000000E+03", "  -1.0000000000XX+03", 1)
    });
    let e = load(&text("harwell-boeing + mapping"), d.path()).unwrap_err();
    assert!(
        e.contains("se.yaml")
            && e.contains("stiffness")
            && e.contains("bench_stiff.hb")
            && e.contains("line 7"),
        "{e}"
    );
    // Harwell–Boeing: a truncated index section.
    let d = broken("bench_mass.hb", |t| {
        t.lines().take(5).collect::<Vec<_>>().join("\n")
    });
    let e = load(&text("harwell-boeing + mapping"), d.path()).unwrap_err();
    assert!(
        e.contains("bench_mass.hb") && e.contains("row indices"),
        "{e}"
    );
    // Abaqus: a line with four fields.
    let d = broken("bench_STIF1.mtx", |t| {
        t.replacen("10,2, 10,2,", "10,2, 10,", 1)
    });
    let e = load(&text("abaqus"), d.path()).unwrap_err();
    assert!(
        e.contains("bench_STIF1.mtx") && e.contains("line 2") && e.contains("4 fields"),
        "{e}"
    );
    // DMIG: the stiffness matrix name is not in the punch file.
    let d = broken("bench.pch", |t| t.replace("KAAX", "KXXX"));
    let e = load(&text("nastran dmig"), d.path()).unwrap_err();
    assert!(
        e.contains("bench.pch") && e.contains("KAAX") && e.contains("KXXX"),
        "{e}"
    );
    // DMIG: a bad value names its line.
    let d = broken("bench.pch", |t| {
        t.replacen("4.000000000D+03", "4.00000000QD+03", 1)
    });
    let e = load(&text("nastran dmig"), d.path()).unwrap_err();
    assert!(
        e.contains("line 5") && e.contains("not a finite number"),
        "{e}"
    );
    // Mapping: an unsupported DOF.
    let d = broken("bench.mapping", |t| t.replacen("UY", "TEMP", 1));
    let e = load(&text("harwell-boeing + mapping"), d.path()).unwrap_err();
    assert!(
        e.contains("bench.mapping") && e.contains("TEMP") && e.contains("line 3"),
        "{e}"
    );
    // A node the labels do not know.
    let t = text("abaqus")
        .replace("id: 20", "id: 21")
        .replace("node: 20", "node: 21");
    let e = load(&t, &fixtures()).unwrap_err();
    assert!(e.contains("nodes[1]") && e.contains("21"), "{e}");
}
