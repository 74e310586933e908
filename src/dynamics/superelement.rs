//! External super-elements: mass and stiffness matrices exported from FE
//! software as Matrix Market files (read with `sprs`), plus a node map from
//! node ids to matrix rows (6 DOFs x, y, z, rx, ry, rz, or 3 translations).
//! File paths are relative to the model file; the caller supplies a resolver
//! that turns such a path into bytes, so the core never guesses directories.
#![allow(non_snake_case)]

use super::error::DynamicsError;
use super::fe_body::{FeBody, FeNode};
use super::model_file::SuperelementSpec;
use super::sparse::Csc;

/// Turns a path written in the model file into the file's bytes.
pub type Resolver<'a> = &'a dyn Fn(&str) -> std::io::Result<Vec<u8>>;

/// A resolver that reads paths relative to `base` (the model file's directory).
pub fn directory_resolver(
    base: &std::path::Path,
) -> impl Fn(&str) -> std::io::Result<Vec<u8>> + '_ {
    move |p: &str| std::fs::read(base.join(p))
}

fn read_matrix(
    path: &str,
    resolver: Resolver<'_>,
    file: &str,
    field: &str,
) -> Result<Csc, DynamicsError> {
    let fail = |message: String| DynamicsError::ExternalFile {
        file: file.to_string(),
        field: field.to_string(),
        path: path.to_string(),
        message,
    };
    let bytes = resolver(path).map_err(|e| fail(e.to_string()))?;
    let mut reader = std::io::BufReader::new(bytes.as_slice());
    let tri: sprs::TriMatI<f64, usize> = sprs::io::read_matrix_market_from_bufread(&mut reader)
        .map_err(|e| fail(format!("not a real Matrix Market coordinate matrix: {e}")))?;
    let (r, c) = (tri.rows(), tri.cols());
    if r != c {
        return Err(fail(format!("matrix is {r}×{c}, expected square")));
    }
    let mut t = Vec::with_capacity(tri.nnz());
    for (v, (i, j)) in tri.triplet_iter() {
        if !v.is_finite() {
            return Err(fail(format!("entry ({}, {}) is not finite", i + 1, j + 1)));
        }
        t.push((i, j, *v));
    }
    let A = Csc::from_triplets(r, t);
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
    let M = read_matrix(&spec.mass, resolver, file, &format!("{field}.mass"))?;
    let K = read_matrix(
        &spec.stiffness,
        resolver,
        file,
        &format!("{field}.stiffness"),
    )?;
    if M.n != K.n {
        return Err(DynamicsError::invalid(
            file,
            field,
            format!("mass is {0}×{0} but stiffness is {1}×{1}", M.n, K.n),
        ));
    }
    let n = M.n;
    let mut nodes = Vec::with_capacity(spec.nodes.len());
    for (i, node) in spec.nodes.iter().enumerate() {
        let f = format!("{field}.nodes[{i}]");
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
            dofs: std::array::from_fn(|j| node.dofs.get(j).copied()),
        });
    }
    Ok(FeBody { M, K, nodes })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> SuperelementSpec {
        SuperelementSpec {
            mass: "m.mtx".into(),
            stiffness: "k.mtx".into(),
            nodes: vec![crate::dynamics::model_file::SuperNodeSpec {
                id: 7,
                dofs: vec![0, 1, 2],
                position: [0.0; 3],
            }],
            points: Default::default(),
            reduction: None,
            loss_factor: 0.0,
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
