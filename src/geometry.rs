//! Test geometry: where the measured nodes are and how they are joined by
//! trace lines, for drawing mode shapes on the structure.
//!
//! Two sources:
//! - a model file: each sensor's and excitation's point (a rigid body's
//!   named point, a beam node `start + (end − start)·n/elements` plus its
//!   offset, a super-element node plus its offset), moved by the axes as in
//!   [`crate::dynamics`] (configurations are the Cartesian product of the
//!   axes' positions, first axis slowest); trace lines join a body's nodes
//!   in the order the file lists them, and each joint between two bodies
//!   joins their nearest measured nodes;
//! - a universal file: node coordinates from datasets 15/2411 and trace
//!   lines from dataset 82 (none: the nodes alone).
//!
//! `geometry.json` (`{"nodes": [{"id", "xyz"}], "lines": [[a, b]]}`) is the
//! serialized form an `import` stage writes.

use crate::dynamics::model_file::{BodySpec, ModelFile};
use crate::io::UffFile;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Node coordinates (m) and trace-line segments of a test structure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Geometry {
    pub nodes: Vec<Node>,
    pub lines: Vec<(u32, u32)>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Node {
    pub id: u32,
    pub xyz: [f64; 3],
}

impl Geometry {
    pub fn coordinates(&self) -> BTreeMap<u32, [f64; 3]> {
        self.nodes.iter().map(|n| (n.id, n.xyz)).collect()
    }

    /// The geometry of configuration `position` of a model file (module
    /// docs). Points that cannot be placed (unknown body or point) are left
    /// out: the model's own validation reports them.
    pub fn from_model_file(spec: &ModelFile, position: usize) -> Geometry {
        let shifts = axis_shifts(spec, position);
        let mut nodes: Vec<Node> = Vec::new();
        // Per body: its measured nodes in file order.
        let mut by_body: BTreeMap<&str, Vec<u32>> = BTreeMap::new();
        for p in spec.sensors.iter().chain(&spec.excitations) {
            let Some(body) = spec.bodies.iter().find(|b| b.name == p.body) else {
                continue;
            };
            let Some(mut xyz) = point(body, &p.point) else {
                continue;
            };
            if let Some(s) = shifts.get(p.body.as_str()) {
                for k in 0..3 {
                    xyz[k] += s[k];
                }
            }
            if !nodes.iter().any(|n| n.id == p.node) {
                nodes.push(Node { id: p.node, xyz });
                by_body.entry(p.body.as_str()).or_default().push(p.node);
            }
        }
        let mut lines: Vec<(u32, u32)> = Vec::new();
        for list in by_body.values() {
            lines.extend(list.windows(2).map(|w| (w[0], w[1])));
        }
        let at = |id: u32| nodes.iter().find(|n| n.id == id).map(|n| n.xyz);
        for j in &spec.joints {
            let Some(b) = &j.b else { continue };
            let (Some(na), Some(nb)) =
                (by_body.get(j.a.body.as_str()), by_body.get(b.body.as_str()))
            else {
                continue;
            };
            let mut best: Option<(f64, (u32, u32))> = None;
            for &x in na {
                for &y in nb {
                    if let (Some(p), Some(q)) = (at(x), at(y)) {
                        let d = dist(p, q);
                        if x != y && best.is_none_or(|(b, _)| d < b) {
                            best = Some((d, (x, y)));
                        }
                    }
                }
            }
            if let Some((_, pair)) = best {
                if !lines.contains(&pair) && !lines.contains(&(pair.1, pair.0)) {
                    lines.push(pair);
                }
            }
        }
        Geometry { nodes, lines }
    }

    /// Nodes (15/2411) and trace lines (82) of a universal file; `None`
    /// when it has no nodes.
    pub fn from_uff(file: &UffFile) -> Option<Geometry> {
        let coordinates = file.node_coordinates();
        let nodes: Vec<Node> = coordinates
            .iter()
            .filter_map(|(&id, &xyz)| {
                Some(Node {
                    id: u32::try_from(id).ok()?,
                    xyz,
                })
            })
            .collect();
        if nodes.is_empty() {
            return None;
        }
        let lines = file
            .trace_segments()
            .into_iter()
            .filter_map(|(a, b)| Some((u32::try_from(a).ok()?, u32::try_from(b).ok()?)))
            .collect();
        Some(Geometry { nodes, lines })
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Coordinates of a named point of a body at axis position 0.
fn point(body: &BodySpec, name: &str) -> Option<[f64; 3]> {
    let plus = |a: [f64; 3], b: [f64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    if let Some(r) = &body.rigid {
        return r.points.get(name).copied();
    }
    if let Some(b) = &body.beam {
        let p = b.points.get(name)?;
        let t = p.node as f64 / b.elements.max(1) as f64;
        let node = [0, 1, 2].map(|k| b.start[k] + (b.end[k] - b.start[k]) * t);
        return Some(plus(node, p.offset));
    }
    let s = body.superelement.as_ref()?;
    let p = s.points.get(name)?;
    let node = s.nodes.iter().find(|n| n.id == p.node)?;
    Some(plus(node.position, p.offset))
}

/// Rigid shift of each moving body in configuration `position`.
fn axis_shifts(spec: &ModelFile, position: usize) -> BTreeMap<&str, [f64; 3]> {
    let mut out: BTreeMap<&str, [f64; 3]> = BTreeMap::new();
    // Mixed-radix digits of `position`, last axis fastest.
    let mut rest = position;
    for ax in spec.axes.iter().rev() {
        let n = ax.positions.len().max(1);
        let s = ax.positions.get(rest % n).copied().unwrap_or(0.0);
        rest /= n;
        let norm = dist(ax.direction, [0.0; 3]).max(f64::MIN_POSITIVE);
        let e = out.entry(ax.body.as_str()).or_insert([0.0; 3]);
        for (e, d) in e.iter_mut().zip(ax.direction) {
            *e += s * d / norm;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_file_points_follow_bodies_beams_and_axes() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/pipelines/models/three_mass.yaml"
        ))
        .unwrap();
        let spec = crate::dynamics::model_file::parse(&text, "three_mass.yaml").unwrap();
        let g = Geometry::from_model_file(&spec, 0);
        assert_eq!(g.coordinates()[&2], [0.1, 0.0, 0.0]);
        assert_eq!(g.nodes.len(), 3);
        // m1–m2 and m2–m3 are joined by joints; ground springs join nothing.
        assert_eq!(g.lines.len(), 2, "{:?}", g.lines);

        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/pipelines/models/uniaxial_test_bench.yaml"
        ))
        .unwrap();
        let spec = crate::dynamics::model_file::parse(&text, "bench.yaml").unwrap();
        let ax = &spec.axes[0];
        let (g0, g1) = (
            Geometry::from_model_file(&spec, 0),
            Geometry::from_model_file(&spec, 1),
        );
        let moving = spec
            .sensors
            .iter()
            .find(|s| s.body == ax.body)
            .unwrap()
            .node;
        let fixed = spec
            .sensors
            .iter()
            .find(|s| s.body != ax.body)
            .unwrap()
            .node;
        let (a, b) = (g0.coordinates()[&moving], g1.coordinates()[&moving]);
        let travel = dist(a, b);
        assert!((travel - (ax.positions[1] - ax.positions[0]).abs()).abs() < 1e-12);
        assert_eq!(g0.coordinates()[&fixed], g1.coordinates()[&fixed]);
        assert!(!g0.lines.is_empty());
    }
}
