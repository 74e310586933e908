//! Constraints of an imported super-element: the DOFs a model file fixes
//! (u = 0: a clamped base, a symmetry plane, a roller) by node ids and/or a
//! selection by coordinates, applied by removing their rows and columns
//! from M and K before anything else reads the matrices.
//!
//! Removing the rows of fixed DOFs is the homogeneous Dirichlet condition
//! of the FE method (Bathe, *Finite Element Procedures*, 2nd ed., 2014,
//! sec. 3.3.2, "imposing u_b = 0 by deleting rows and columns"): with u
//! split into free f and fixed b parts, u_b = 0 leaves K_ff φ = λ M_ff φ,
//! exactly the matrices an FE program exports after its own clamp. Node
//! rows of the model file stay in the files' numbering; the body's node map
//! is renumbered here, and a node whose every DOF is fixed keeps no row.
//!
//! Decision on sensors: a fixed DOF has no row, so a point on a partly
//! fixed node reads zero in its fixed directions (a roller's normal
//! motion); a named point on a node fixed in every DOF is an error naming
//! the point, since every sensor, excitation, joint or mass there would see
//! nothing.

use super::error::DynamicsError;
use super::fe_body::FeNode;
use super::model_file::{ConstraintSpec, NodePointSpec};
use crate::io::fe::DofLabel;
use std::collections::BTreeMap;

/// DOF names in row order of a node (x, y, z, rx, ry, rz).
const DOF_NAMES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

/// Which of the `n` rows the constraints fix. `nodes` is the body's node
/// map (rows in the files' numbering), `labels` the files' row labels
/// (node, DOF 1–6) when they carry them; `field` is the super-element's
/// field path for messages.
pub fn fixed_dofs(
    constraints: &[ConstraintSpec],
    nodes: &[FeNode],
    labels: Option<&[DofLabel]>,
    n: usize,
    file: &str,
    field: &str,
) -> Result<Vec<bool>, DynamicsError> {
    let mut fixed = vec![false; n];
    for (i, c) in constraints.iter().enumerate() {
        let f = format!("{field}.constraints[{i}]");
        let inv = |sub: &str, m: String| {
            let who = c
                .name
                .as_ref()
                .map_or(String::new(), |n| format!("`{n}`: "));
            DynamicsError::invalid(file, format!("{f}{sub}"), format!("{who}{m}"))
        };
        let selected = select(c, nodes, labels, &inv)?;
        let dirs: Vec<usize> = match &c.dofs {
            Some(d) if d.is_empty() => {
                return Err(inv(".dofs", "is empty: list the fixed directions (x, y, z, rx, ry, rz) or leave it out to clamp".into()));
            }
            Some(d) => d.iter().map(|d| d.index()).collect(),
            None => (0..6).collect(),
        };
        // Listed directions must exist somewhere; the default clamps what is there.
        for &d in dirs.iter().filter(|_| c.dofs.is_some()) {
            if !selected.iter().any(|rows| rows[d].is_some()) {
                return Err(inv(
                    ".dofs",
                    format!(
                        "no selected node has a `{}` DOF (translational-only nodes have x, y, z)",
                        DOF_NAMES[d]
                    ),
                ));
            }
        }
        for rows in &selected {
            for &d in &dirs {
                if let Some(r) = rows[d] {
                    fixed[r] = true;
                }
            }
        }
    }
    if fixed.iter().all(|&f| f) {
        return Err(DynamicsError::invalid(
            file,
            format!("{field}.constraints"),
            format!("fix all {n} DOFs of the body: nothing is left to move"),
        ));
    }
    Ok(fixed)
}

/// The rows (x, y, z, rx, ry, rz) of every node one constraint selects:
/// listed ids, then nodes of the node map on the plane or in the box.
fn select(
    c: &ConstraintSpec,
    nodes: &[FeNode],
    labels: Option<&[DofLabel]>,
    inv: &dyn Fn(&str, String) -> DynamicsError,
) -> Result<Vec<[Option<usize>; 6]>, DynamicsError> {
    if c.nodes.is_empty() && c.plane.is_none() && c.inside.is_none() {
        return Err(inv(
            "",
            "selects nothing: give `nodes` (ids), `plane` or `box`".into(),
        ));
    }
    let mut out = Vec::new();
    for (k, &id) in c.nodes.iter().enumerate() {
        out.push(node_rows(id, nodes, labels).ok_or_else(|| {
            let known = if labels.is_some() {
                "neither listed in `nodes:` nor labelled in the matrix files"
            } else {
                "not listed in `nodes:` (the matrix files carry no node labels, so list it there with its rows)"
            };
            inv(&format!(".nodes[{k}]"), format!("unknown node {id}: {known}"))
        })?);
    }
    let before = out.len();
    if let Some(p) = &c.plane {
        if !(p.value.is_finite() && p.tol.is_finite() && p.tol >= 0.0) {
            return Err(inv(
                ".plane",
                "value and tol must be finite, tol >= 0 (m)".into(),
            ));
        }
        let a = p.axis.index();
        let on = |x: &FeNode| (x.position[a] - p.value).abs() <= p.tol;
        out.extend(nodes.iter().filter(|x| on(x)).map(|x| x.dofs));
    }
    if let Some(b) = &c.inside {
        let ok =
            (0..3).all(|k| b.min[k].is_finite() && b.max[k].is_finite() && b.min[k] <= b.max[k]);
        if !ok {
            return Err(inv(
                ".box",
                "min and max must be finite with min <= max in x, y and z (m)".into(),
            ));
        }
        let inside =
            |x: &FeNode| (0..3).all(|k| b.min[k] <= x.position[k] && x.position[k] <= b.max[k]);
        out.extend(nodes.iter().filter(|x| inside(x)).map(|x| x.dofs));
    }
    if out.len() == before && (c.plane.is_some() || c.inside.is_some()) {
        let (what, sub) = match (&c.plane, &c.inside) {
            (Some(p), None) => (
                format!("the plane {:?} = {} ± {} m", p.axis, p.value, p.tol).to_lowercase(),
                ".plane",
            ),
            (None, Some(_)) => ("the box".to_string(), ".box"),
            _ => ("the plane and the box".to_string(), ""),
        };
        return Err(inv(
            sub,
            format!(
                "selects no node: {what} holds none of the {} nodes listed in `nodes:` (coordinate selections see only those; list the nodes to fix there with their positions, or check the units: m)",
                nodes.len()
            ),
        ));
    }
    Ok(out)
}

/// Rows of node `id`: from the node map, else from the files' labels.
fn node_rows(id: u64, nodes: &[FeNode], labels: Option<&[DofLabel]>) -> Option<[Option<usize>; 6]> {
    if let Some(x) = nodes.iter().find(|x| x.id == id) {
        return Some(x.dofs);
    }
    let labels = labels?;
    let rows: [Option<usize>; 6] =
        std::array::from_fn(|d| labels.binary_search(&(id, d as u8 + 1)).ok());
    rows.iter().any(Option::is_some).then_some(rows)
}

/// Old row → new row (`None` for a fixed row) and the number of free rows.
pub fn renumbering(fixed: &[bool]) -> (Vec<Option<usize>>, usize) {
    let mut next = 0;
    let map = fixed
        .iter()
        .map(|&f| {
            (!f).then(|| {
                next += 1;
                next - 1
            })
        })
        .collect();
    (map, next)
}

/// The triplets of the free rows and columns, renumbered (K_ff, M_ff).
/// Entries outside the map are kept beyond every free row, so the size
/// check that follows still refuses them.
pub fn remove_dofs(t: Vec<(usize, usize, f64)>, map: &[Option<usize>]) -> Vec<(usize, usize, f64)> {
    let to = |i: usize| map.get(i).map_or(Some(usize::MAX), |r| *r);
    t.into_iter()
        .filter_map(|(i, j, v)| Some((to(i)?, to(j)?, v)))
        .collect()
}

/// The node map in the free rows' numbering.
pub fn renumber_nodes(nodes: &mut [FeNode], map: &[Option<usize>]) {
    for x in nodes {
        for d in x.dofs.iter_mut() {
            *d = d.and_then(|r| map.get(r).copied().flatten());
        }
    }
}

/// A named point may not sit on a node whose every DOF is fixed.
pub fn check_points(
    points: &BTreeMap<String, NodePointSpec>,
    nodes: &[FeNode],
    fixed: &[bool],
    file: &str,
    field: &str,
) -> Result<(), DynamicsError> {
    for (name, p) in points {
        let Some(x) = nodes.iter().find(|x| x.id == p.node) else {
            continue; // unknown nodes are reported with the points
        };
        let rows: Vec<usize> = x.dofs.iter().flatten().copied().collect();
        if !rows.is_empty() && rows.iter().all(|&r| fixed.get(r) == Some(&true)) {
            return Err(DynamicsError::invalid(
                file,
                format!("{field}.points.{name}"),
                format!(
                    "is on node {}, which the constraints fix in every DOF: a sensor, excitation, joint or mass there would not move; put the point on a free node",
                    p.node
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::model_file::{Axis, BoxSpec, Direction, PlaneSpec};

    /// Four 3-DOF nodes on a line x = 0, 1, 2, 3 (rows 3i..3i+3).
    fn line() -> Vec<FeNode> {
        (0..4)
            .map(|i| FeNode {
                id: 10 + i as u64,
                position: [i as f64, 0.0, 0.0],
                dofs: [
                    Some(3 * i),
                    Some(3 * i + 1),
                    Some(3 * i + 2),
                    None,
                    None,
                    None,
                ],
            })
            .collect()
    }

    fn constraint() -> ConstraintSpec {
        ConstraintSpec {
            name: Some("base".into()),
            dofs: None,
            nodes: vec![],
            plane: None,
            inside: None,
        }
    }

    fn fixed(c: ConstraintSpec, labels: Option<&[DofLabel]>) -> Result<Vec<bool>, String> {
        fixed_dofs(
            &[c],
            &line(),
            labels,
            12,
            "m.yaml",
            "bodies[2].superelement",
        )
        .map_err(|e| e.to_string())
    }

    #[test]
    fn selections_fix_the_rows_of_their_nodes() {
        let by_id = ConstraintSpec {
            nodes: vec![11],
            dofs: Some(vec![Direction::Y]),
            ..constraint()
        };
        let f = fixed(by_id, None).unwrap();
        assert_eq!(f.iter().positions(), vec![4]);
        let plane = PlaneSpec {
            axis: Axis::X,
            value: 3.0,
            tol: 1e-6,
        };
        let f = fixed(
            ConstraintSpec {
                plane: Some(plane),
                ..constraint()
            },
            None,
        )
        .unwrap();
        assert_eq!(f.iter().positions(), vec![9, 10, 11]);
        let inside = BoxSpec {
            min: [-0.5, -1.0, -1.0],
            max: [1.0, 1.0, 1.0],
        };
        let f = fixed(
            ConstraintSpec {
                inside: Some(inside),
                ..constraint()
            },
            None,
        )
        .unwrap();
        assert_eq!(f.iter().positions(), (0..6).collect::<Vec<_>>());
        // A node only the files' labels know (id 99, rows 0..3 of the labels).
        let labels: Vec<DofLabel> = vec![(99, 1), (99, 2), (99, 3)];
        let c = ConstraintSpec {
            nodes: vec![99],
            ..constraint()
        };
        let f = fixed_dofs(&[c], &[], Some(&labels), 6, "m.yaml", "b").unwrap();
        assert_eq!(f.iter().positions(), vec![0, 1, 2]);
    }

    #[test]
    fn bad_selections_name_the_body_and_the_entry() {
        let e = fixed(
            ConstraintSpec {
                nodes: vec![10, 7],
                ..constraint()
            },
            None,
        )
        .unwrap_err();
        assert!(
            e.contains("bodies[2].superelement.constraints[0].nodes[1]")
                && e.contains("unknown node 7")
                && e.contains("`base`"),
            "{e}"
        );
        let plane = PlaneSpec {
            axis: Axis::Z,
            value: 1.0,
            tol: 1e-6,
        };
        let e = fixed(
            ConstraintSpec {
                plane: Some(plane),
                ..constraint()
            },
            None,
        )
        .unwrap_err();
        assert!(
            e.contains("constraints[0].plane")
                && e.contains("selects no node")
                && e.contains("z = 1"),
            "{e}"
        );
        let e = fixed(constraint(), None).unwrap_err();
        assert!(e.contains("selects nothing"), "{e}");
        let rot = ConstraintSpec {
            nodes: vec![10],
            dofs: Some(vec![Direction::Rx]),
            ..constraint()
        };
        let e = fixed(rot, None).unwrap_err();
        assert!(e.contains("`rx`"), "{e}");
        let all = BoxSpec {
            min: [-9.0; 3],
            max: [9.0; 3],
        };
        let e = fixed(
            ConstraintSpec {
                inside: Some(all),
                ..constraint()
            },
            None,
        )
        .unwrap_err();
        assert!(e.contains("all 12 DOFs"), "{e}");
    }

    #[test]
    fn removal_keeps_the_free_block_and_renumbers_the_nodes() {
        // K = tridiagonal(−1, 2, −1) of size 4; fix row 1.
        let mut t = Vec::new();
        for i in 0..4 {
            t.push((i, i, 2.0));
            if i + 1 < 4 {
                t.push((i, i + 1, -1.0));
                t.push((i + 1, i, -1.0));
            }
        }
        let (map, n) = renumbering(&[false, true, false, false]);
        assert_eq!((map.clone(), n), (vec![Some(0), None, Some(1), Some(2)], 3));
        let mut r = remove_dofs(t, &map);
        r.sort_by_key(|e| (e.0, e.1));
        assert_eq!(
            r,
            vec![
                (0, 0, 2.0),
                (1, 1, 2.0),
                (1, 2, -1.0),
                (2, 1, -1.0),
                (2, 2, 2.0)
            ]
        );
        let mut nodes = vec![FeNode {
            id: 1,
            position: [0.0; 3],
            dofs: [Some(0), Some(1), Some(3), None, None, None],
        }];
        renumber_nodes(&mut nodes, &map);
        assert_eq!(nodes[0].dofs, [Some(0), None, Some(2), None, None, None]);
    }

    #[test]
    fn a_point_on_a_fully_fixed_node_is_an_error() {
        let points = BTreeMap::from([(
            "tip".to_string(),
            NodePointSpec {
                node: 11,
                offset: [0.0; 3],
            },
        )]);
        let mut f = vec![false; 12];
        f[3] = true;
        assert!(check_points(&points, &line(), &f, "m.yaml", "b").is_ok());
        f[4] = true;
        f[5] = true;
        let e = check_points(&points, &line(), &f, "m.yaml", "b")
            .unwrap_err()
            .to_string();
        assert!(e.contains("b.points.tip") && e.contains("node 11"), "{e}");
    }

    trait Positions {
        fn positions(self) -> Vec<usize>;
    }

    impl<'a, I: Iterator<Item = &'a bool>> Positions for I {
        fn positions(self) -> Vec<usize> {
            self.enumerate()
                .filter(|(_, &b)| b)
                .map(|(i, _)| i)
                .collect()
        }
    }
}
