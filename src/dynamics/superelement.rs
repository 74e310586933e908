//! External super-elements: mass and stiffness matrices exported from FE
//! software (Matrix Market, Harwell–Boeing, Abaqus and Nastran DMIG, read
//! by [`crate::io::fe`]), plus a node map from node ids to
//! matrix rows (6 DOFs x, y, z, rx, ry, rz, or 3 translations), given or
//! taken from the files' node/DOF labels; constrained DOFs removed first
//! ([`super::constraints`]).
//! File paths are relative to the model file; the caller supplies a resolver
//! that turns such a path into bytes, so the core never guesses directories.
#![allow(non_snake_case)]

use super::constraints;
use super::error::DynamicsError;
use super::fe_body::{FeBody, FeNode};
use super::model_file::{FeFormat, SuperelementSpec};
use super::sparse::Csc;
use crate::io::fe::{self, DofLabel, FeMatrix};

/// Turns a path written in the model file into the file's bytes.
pub type Resolver<'a> = &'a dyn Fn(&str) -> std::io::Result<Vec<u8>>;

/// A resolver that reads paths relative to `base` (the model file's directory).
pub fn directory_resolver(
    base: &std::path::Path,
) -> impl Fn(&str) -> std::io::Result<Vec<u8>> + '_ {
    move |p: &str| std::fs::read(base.join(p))
}

/// One matrix file read in its format.
fn read_matrix(
    path: &str,
    spec: &SuperelementSpec,
    dmig_name: &str,
    resolver: Resolver<'_>,
    file: &str,
    field: &str,
) -> Result<FeMatrix, DynamicsError> {
    let fail = |message: String| DynamicsError::ExternalFile {
        file: file.to_string(),
        field: field.to_string(),
        path: path.to_string(),
        message,
    };
    let bytes = resolver(path).map_err(|e| fail(e.to_string()))?;
    let text = std::str::from_utf8(&bytes).ok();
    let format = match (spec.format, text) {
        (Some(f), _) => f,
        (None, Some(t)) => sniff(t).ok_or_else(|| {
            fail("format not recognized: set `format:` to matrix_market, harwell_boeing, abaqus or nastran_dmig".into())
        })?,
        (None, None) => FeFormat::MatrixMarket,
    };
    let text_of = || text.ok_or_else(|| fail("not a text file (UTF-8)".into()));
    let located = |e: fe::FeError| fail(e.to_string());
    let m = match format {
        FeFormat::MatrixMarket => fe::read_matrix_market(text_of()?).map_err(located)?,
        FeFormat::HarwellBoeing => fe::read_harwell_boeing(text_of()?).map_err(located)?,
        FeFormat::Abaqus => fe::read_abaqus_mtx(text_of()?).map_err(located)?,
        FeFormat::NastranDmig => fe::read_dmig(text_of()?, dmig_name).map_err(located)?,
    };
    if let Some((i, j, _)) = m.entries.iter().find(|e| !e.2.is_finite()) {
        return Err(fail(format!("entry ({}, {}) is not finite", i + 1, j + 1)));
    }
    Ok(m)
}

/// The format of an FE export from its first lines.
fn sniff(text: &str) -> Option<FeFormat> {
    let lines: Vec<&str> = text.lines().take(5).collect();
    let first = lines.iter().find(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with("**") && !t.starts_with('$')
    })?;
    if first.starts_with("%%MatrixMarket") {
        return Some(FeFormat::MatrixMarket);
    }
    if text
        .lines()
        .any(|l| l.trim_start().to_ascii_uppercase().starts_with("DMIG"))
    {
        return Some(FeFormat::NastranDmig);
    }
    let commas = first.split(',').count();
    if commas == 5 || commas == 3 {
        return Some(FeFormat::Abaqus);
    }
    let mxtype = lines.get(2).and_then(|l| l.get(..3)).unwrap_or("");
    if ["RSA", "RUA"].contains(&mxtype.to_ascii_uppercase().as_str()) {
        return Some(FeFormat::HarwellBoeing);
    }
    None
}

/// Renumber `m` to the rows of `labels` (which contain all of its own); a
/// row without a label becomes `usize::MAX`, which [`check_rows`] refuses.
fn relabel(m: FeMatrix, labels: &[DofLabel]) -> Vec<(usize, usize, f64)> {
    let own = m.labels.unwrap_or_default();
    let map: Vec<usize> = own
        .iter()
        .map(|l| labels.binary_search(l).unwrap_or(usize::MAX))
        .collect();
    let to = |i: usize| map.get(i).copied().unwrap_or(usize::MAX);
    m.entries
        .into_iter()
        .map(|(i, j, v)| (to(i), to(j), v))
        .collect()
}

/// Every entry of M and K inside the n × n matrices, and every one of the n
/// rows holding at least one entry of M or K. A row with neither is a DOF
/// without mass and stiffness (the pencil K − λM is singular there); a size
/// line claiming more rows than the entries touch is refused here, before
/// matrices of that size are built. Time and memory follow the entries,
/// not `n`.
fn check_rows(
    m: &[(usize, usize, f64)],
    k: &[(usize, usize, f64)],
    n: usize,
) -> Result<(), String> {
    let mut rows: Vec<usize> = Vec::new();
    for &(i, j, _) in m.iter().chain(k) {
        if i >= n || j >= n {
            return Err(format!(
                "entry ({}, {}) is outside the {n}×{n} matrices",
                i.saturating_add(1),
                j.saturating_add(1)
            ));
        }
        rows.extend([i, j]);
    }
    rows.sort_unstable();
    rows.dedup();
    if rows.len() == n {
        return Ok(());
    }
    let first = rows
        .iter()
        .enumerate()
        .find(|&(k, &r)| r != k)
        .map_or(rows.len(), |(k, _)| k);
    Err(format!(
        "{} of the {n} rows have no entry in the mass or the stiffness matrix (the first is row \
         {}, 1-based): a DOF without mass and stiffness makes the eigenproblem singular; the \
         declared size is wrong or the export lists unused DOFs",
        n - rows.len(),
        first + 1
    ))
}

/// The loaded super-element (and its dense Craig–Bampton matrices when it
/// is reduced) against the memory limit, before the matrices are built.
fn check_memory(n: usize, entries: usize, reduced: bool) -> Result<(), String> {
    let sparse = fe::matrix_bytes(n, entries);
    let dense = if reduced {
        8.0 * 4.0 * (n as f64).powi(2)
    } else {
        0.0
    };
    let limit = crate::resources::memory_limit() as f64;
    if sparse + dense <= limit {
        return Ok(());
    }
    let human = crate::resources::human;
    Err(format!(
        "{n} DOF and {entries} matrix entries need an estimated {}{}, more than the memory limit \
         of {} (--max-memory){}",
        human(sparse + dense),
        if reduced {
            " held dense for the Craig–Bampton reduction"
        } else {
            ""
        },
        human(limit),
        if reduced {
            "; drop the reduction (sparse solver) or raise the limit"
        } else {
            "; raise the limit"
        }
    ))
}

fn symmetric(
    t: Vec<(usize, usize, f64)>,
    n: usize,
    fail: impl Fn(String) -> DynamicsError,
) -> Result<Csc, DynamicsError> {
    let A = Csc::from_triplets(n, t);
    if let Some((i, j, a, b)) = A.asymmetry(1e-9) {
        return Err(fail(format!(
            "matrix is not symmetric at ({}, {}): {a} vs {b}",
            i + 1,
            j + 1
        )));
    }
    Ok(A)
}

/// Load a super-element. `field` is the body's field path for messages.
pub fn load_superelement(
    spec: &SuperelementSpec,
    resolver: Resolver<'_>,
    file: &str,
    field: &str,
) -> Result<FeBody, DynamicsError> {
    let fm = format!("{field}.mass");
    let fk = format!("{field}.stiffness");
    let name_m = spec.mass_matrix.as_deref().unwrap_or("MAAX");
    let name_k = spec.stiffness_matrix.as_deref().unwrap_or("KAAX");
    let mut Mf = read_matrix(&spec.mass, spec, name_m, resolver, file, &fm)?;
    let mut Kf = read_matrix(&spec.stiffness, spec, name_k, resolver, file, &fk)?;
    if let Some(path) = &spec.mapping {
        let fmap = format!("{field}.mapping");
        let err = |message: String| DynamicsError::ExternalFile {
            file: file.to_string(),
            field: fmap.clone(),
            path: path.clone(),
            message,
        };
        let bytes = resolver(path).map_err(|e| err(e.to_string()))?;
        let text = std::str::from_utf8(&bytes).map_err(|_| err("not a text file".into()))?;
        let labels = fe::read_ansys_mapping(text).map_err(|e| err(e.to_string()))?;
        for m in [&mut Mf, &mut Kf] {
            if labels.len() != m.n {
                return Err(err(format!(
                    "maps {} equations, the matrices have {}",
                    labels.len(),
                    m.n
                )));
            }
            m.labels = Some(labels.clone());
        }
    }
    // A common row numbering: the union of both files' labels, or the
    // files' own numbering when they carry none.
    let labels: Option<Vec<DofLabel>> = match (&Mf.labels, &Kf.labels) {
        (Some(a), Some(b)) => {
            let mut l: Vec<DofLabel> = a.iter().chain(b).copied().collect();
            l.sort_unstable();
            l.dedup();
            Some(l)
        }
        (None, None) => None,
        _ => {
            return Err(DynamicsError::invalid(
                file,
                field,
                "one matrix file labels its rows by node and DOF, the other does not; export both the same way",
            ))
        }
    };
    let (n, tm, tk) = match &labels {
        Some(l) => (l.len(), relabel(Mf, l), relabel(Kf, l)),
        None => {
            if Mf.n != Kf.n {
                return Err(DynamicsError::invalid(
                    file,
                    field,
                    format!("mass is {0}×{0} but stiffness is {1}×{1}", Mf.n, Kf.n),
                ));
            }
            (Mf.n, Mf.entries, Kf.entries)
        }
    };
    let invalid = |m: String| {
        let files = format!("mass `{}`, stiffness `{}`", spec.mass, spec.stiffness);
        DynamicsError::invalid(file, field, format!("{m} ({files})"))
    };
    check_rows(&tm, &tk, n).map_err(invalid)?;
    let mut nodes = node_map(spec, labels.as_deref(), n, file, field)?;
    // Constraints first: every later step sees K_ff and M_ff only.
    let (n, tm, tk) = if spec.constraints.is_empty() {
        (n, tm, tk)
    } else {
        let l = labels.as_deref();
        let fixed = constraints::fixed_dofs(&spec.constraints, &nodes, l, n, file, field)?;
        constraints::check_points(&spec.points, &nodes, &fixed, file, field)?;
        let (map, free) = constraints::renumbering(&fixed);
        constraints::renumber_nodes(&mut nodes, &map);
        let (tm, tk) = (
            constraints::remove_dofs(tm, &map),
            constraints::remove_dofs(tk, &map),
        );
        (free, tm, tk)
    };
    check_memory(n, tm.len() + tk.len(), spec.reduction.is_some()).map_err(invalid)?;
    let M = symmetric(tm, n, |m| matrix_error(file, &fm, &spec.mass, m))?;
    let K = symmetric(tk, n, |m| matrix_error(file, &fk, &spec.stiffness, m))?;
    Ok(FeBody { M, K, nodes })
}

fn matrix_error(file: &str, field: &str, path: &str, message: String) -> DynamicsError {
    DynamicsError::ExternalFile {
        file: file.to_string(),
        field: field.to_string(),
        path: path.to_string(),
        message,
    }
}

/// The nodes of the spec with their DOF rows, given or from the labels.
fn node_map(
    spec: &SuperelementSpec,
    labels: Option<&[DofLabel]>,
    n: usize,
    file: &str,
    field: &str,
) -> Result<Vec<FeNode>, DynamicsError> {
    let mut nodes = Vec::with_capacity(spec.nodes.len());
    for (i, node) in spec.nodes.iter().enumerate() {
        let f = format!("{field}.nodes[{i}]");
        let dofs: Vec<Option<usize>> = if node.dofs.is_empty() {
            let Some(labels) = labels else {
                return Err(DynamicsError::invalid(
                    file,
                    format!("{f}.dofs"),
                    "missing: the matrix files carry no node/DOF labels, so list the node's 6 (or 3) 0-based rows",
                ));
            };
            let rows: Vec<Option<usize>> = (1..=6u8)
                .map(|d| labels.binary_search(&(node.id, d)).ok())
                .collect();
            if rows[..3].iter().any(Option::is_none) {
                return Err(DynamicsError::invalid(
                    file,
                    format!("{f}.id"),
                    format!(
                        "node {} has no x, y and z rows in the matrix files",
                        node.id
                    ),
                ));
            }
            rows
        } else {
            if node.dofs.len() != 6 && node.dofs.len() != 3 {
                return Err(DynamicsError::invalid(
                    file,
                    format!("{f}.dofs"),
                    format!(
                        "has {} entries; give 6 (x y z rx ry rz) or 3 (x y z) 0-based matrix rows",
                        node.dofs.len()
                    ),
                ));
            }
            if let Some(&bad) = node.dofs.iter().find(|&&d| d >= n) {
                return Err(DynamicsError::invalid(
                    file,
                    format!("{f}.dofs"),
                    format!("row {bad} is outside the {n}×{n} matrices (rows are 0-based)"),
                ));
            }
            (0..6).map(|j| node.dofs.get(j).copied()).collect()
        };
        if node.position.iter().any(|x| !x.is_finite()) {
            return Err(DynamicsError::invalid(
                file,
                format!("{f}.position"),
                "must be finite",
            ));
        }
        if spec.nodes[..i].iter().any(|o| o.id == node.id) {
            return Err(DynamicsError::invalid(
                file,
                format!("{f}.id"),
                format!("node id {} appears twice", node.id),
            ));
        }
        nodes.push(FeNode {
            id: node.id,
            position: node.position,
            dofs: std::array::from_fn(|j| dofs[j]),
        });
    }
    Ok(nodes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> SuperelementSpec {
        SuperelementSpec {
            mass: "m.mtx".into(),
            stiffness: "k.mtx".into(),
            format: None,
            mass_matrix: None,
            stiffness_matrix: None,
            mapping: None,
            nodes: vec![crate::dynamics::model_file::SuperNodeSpec {
                id: 7,
                dofs: vec![0, 1, 2],
                position: [0.0; 3],
            }],
            points: Default::default(),
            reduction: None,
            loss_factor: 0.0,
            constraints: vec![],
        }
    }

    #[test]
    fn reads_symmetric_matrix_market() {
        let resolver = |p: &str| -> std::io::Result<Vec<u8>> {
            Ok(match p {
                "m.mtx" => b"%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2.0\n2 2 2.0\n3 3 2.0\n".to_vec(),
                _ => b"%%MatrixMarket matrix coordinate real symmetric\n3 3 4\n1 1 2.0\n2 1 -1.0\n2 2 2.0\n3 3 1.0\n".to_vec(),
            })
        };
        let b =
            load_superelement(&spec(), &resolver, "model.yaml", "bodies[0].superelement").unwrap();
        assert_eq!(b.K.get(0, 1), -1.0);
        assert_eq!(b.K.get(1, 0), -1.0);
        assert_eq!(b.M.get(2, 2), 2.0);
        assert_eq!(b.nodes[0].dofs[3], None);
    }

    #[test]
    fn missing_file_names_model_field_and_path() {
        let resolver = |_: &str| -> std::io::Result<Vec<u8>> {
            Err(std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "no such file",
            ))
        };
        let e = load_superelement(&spec(), &resolver, "model.yaml", "bodies[0].superelement")
            .unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("model.yaml")
                && s.contains("bodies[0].superelement.mass")
                && s.contains("m.mtx"),
            "{s}"
        );
    }
}
