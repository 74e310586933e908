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

/// Sizes read from a file are bounded before anything is allocated: a
/// Matrix Market header claiming 10¹² entries (which used to abort on a
/// 16 TB allocation) and Harwell–Boeing, mapping and Abaqus counts of the
/// same kind are clean errors naming the file and line; an entry outside
/// the declared size (which used to panic) names its line.
#[test]
fn absurd_sizes_and_out_of_range_entries_are_located_errors() {
    let c = cases();
    let text = |name: &str| c.iter().find(|(n, _)| *n == name).unwrap().1.clone();
    let mm = text("matrix market");
    // 10¹² entries declared, three given.
    let d = broken("bench_k.mtx", |t| {
        t.replacen("6 6 9", "6 6 1000000000000", 1)
    });
    let e = load(&mm, d.path()).unwrap_err();
    assert!(
        e.contains("bench_k.mtx")
            && e.contains("stiffness")
            && e.contains("line 2")
            && e.contains("1000000000000 entries"),
        "{e}"
    );
    // A row index beyond the declared 6 × 6.
    let d = broken("bench_m.mtx", |t| t.replacen("3 3 2.0", "7 3 2.0", 1));
    let e = load(&mm, d.path()).unwrap_err();
    assert!(
        e.contains("bench_m.mtx") && e.contains("line 5") && e.contains("row index 7"),
        "{e}"
    );
    // Index 0 (Matrix Market is 1-based).
    let d = broken("bench_m.mtx", |t| t.replacen("3 3 2.0", "3 0 2.0", 1));
    let e = load(&mm, d.path()).unwrap_err();
    assert!(e.contains("line 5") && e.contains("column index 0"), "{e}");
    // A size beyond any memory limit, from a file of a few lines.
    let d = broken("bench_m.mtx", |t| {
        t.replacen("6 6 6", "1000000000000000 1000000000000000 6", 1)
    });
    let e = load(&mm, d.path()).unwrap_err();
    assert!(
        e.contains("bench_m.mtx") && e.contains("line 2") && e.contains("memory limit"),
        "{e}"
    );
    // Harwell–Boeing: NNZERO far beyond the cards that follow.
    let hb = text("harwell-boeing + mapping");
    let d = broken("bench_mass.hb", |t| {
        t.replacen(
            "RSA                        6             6             6",
            "RSA                        6             6 1000000000000",
            1,
        )
    });
    let e = load(&hb, d.path()).unwrap_err();
    assert!(
        e.contains("bench_mass.hb") && e.contains("line 3") && e.contains("cannot fit"),
        "{e}"
    );
    // The mapping numbering an equation 10¹².
    let d = broken("bench.mapping", |t| {
        t.replacen("          4     20", "1000000000000     20", 1)
    });
    let e = load(&hb, d.path()).unwrap_err();
    assert!(
        e.contains("bench.mapping") && e.contains("line 5") && e.contains("1000000000000"),
        "{e}"
    );
}

/// The declared size must be carried by the entries: a size line claiming
/// rows that neither matrix touches is refused (naming the first such row)
/// before matrices of that size are built, whatever the memory limit.
#[test]
fn rows_without_mass_or_stiffness_are_refused() {
    let mm = model(
        "      mass: bench_m.mtx\n      stiffness: bench_k.mtx",
        ROW_NODES,
    );
    let d = broken("bench_m.mtx", |t| t.replacen("6 6 6", "7 7 6", 1));
    std::fs::write(
        d.path().join("bench_k.mtx"),
        std::fs::read_to_string(fixtures().join("bench_k.mtx"))
            .unwrap()
            .replacen("6 6 9", "7 7 9", 1),
    )
    .unwrap();
    let e = load(&mm, d.path()).unwrap_err();
    assert!(
        e.contains("1 of the 7 rows") && e.contains("row 7") && e.contains("bench_m.mtx"),
        "{e}"
    );
    // An Abaqus coordinate line with index 10¹².
    let plain = "1, 1, 2.0\n2, 2, 2.0\n3, 3, 2.0\n1000000000000, 1000000000000, 2.0\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.mtx"), plain).unwrap();
    std::fs::write(dir.path().join("k.mtx"), plain).unwrap();
    let abq = model(
        "      mass: m.mtx\n      stiffness: k.mtx\n      format: abaqus",
        "        - {id: 10, dofs: [0, 1, 2], position: [0, 0, 0]}",
    )
    .replace("node: 20", "node: 10");
    let e = load(&abq, dir.path()).unwrap_err();
    assert!(
        e.contains("m.mtx") && (e.contains("memory limit") || e.contains("no entry")),
        "{e}"
    );
}

/// `modalflow validate` on two ~80-byte Matrix Market files claiming 10⁹
/// rows refuses them at the size line (it used to build 8 GB column
/// arrays for each before refusing; measured by hand with `/usr/bin/time
/// -v`: 15.6 GB peak and 44 s before, 10 MB and 0.00 s after).
#[test]
fn validate_refuses_a_billion_row_header_at_its_line() {
    use crate::util::{text, Workspace};
    let ws = Workspace::new();
    let mtx = "%%MatrixMarket matrix coordinate real symmetric\n1000000000 1000000000 1\n1 1 2.0\n";
    ws.write("m.mtx", mtx);
    ws.write("k.mtx", mtx);
    ws.write(
        "model.yaml",
        &model("      mass: m.mtx\n      stiffness: k.mtx", ROW_NODES),
    );
    ws.write(
        "p.yaml",
        "name: big\nstages:\n  truth:\n    kind: synthesize\n    params:\n      model: model.yaml\n      frequency: {min: 0, max: 400, step: 0.25}\n",
    );
    let out = ws.cmd(&["validate", "p.yaml", "--max-memory", "256M"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("m.mtx")
            && err.contains("line 2")
            && err.contains("1000000000 rows")
            && err.contains("memory limit of 256.0 MiB"),
        "{err}"
    );
}
