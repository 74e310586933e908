//! Axis positions → model configurations, and where every joint end, sensor
//! and excitation sits in each configuration.
//!
//! Each axis moves its body rigidly by s·d (s = listed position, d = unit
//! direction); configurations are the Cartesian product of all axes'
//! positions, labelled like `wpt=0.250`. For a *sliding* joint (guide shoe
//! on a rail, nut on the screw) end `a` is on the moving body and end `b`'s
//! attachment follows it: on a rigid body exactly at the moving point, on a
//! flexible body at the node nearest to the moving point (minus the named
//! point's offset) — nodes are snapped, not interpolated, so the
//! attachment is always an FE node that can be a Craig-Bampton boundary
//! node; use a node spacing that resolves the travel.

use super::model::{BodyKind, End, Model};

/// A point of a body in one configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Location {
    /// Rigid body: offset r = p − cg, m.
    Rigid([f64; 3]),
    /// FE body: node index and rigid offset, m.
    Node(usize, [f64; 3]),
}

/// Axis positions of one configuration.
#[derive(Debug, Clone)]
pub(crate) struct AxisState {
    pub positions: Vec<f64>,
    pub label: String,
}

/// Cartesian product of all axes' positions (first axis slowest).
pub(crate) fn axis_states(model: &Model) -> Vec<AxisState> {
    let mut states = vec![AxisState {
        positions: Vec::new(),
        label: String::new(),
    }];
    for ax in &model.axes {
        let mut next = Vec::new();
        for s in &states {
            for &p in &ax.positions {
                let mut positions = s.positions.clone();
                positions.push(p);
                let sep = if s.label.is_empty() { "" } else { "," };
                next.push(AxisState {
                    positions,
                    label: format!("{}{sep}{}={p:.3}", s.label, ax.name),
                });
            }
        }
        states = next;
    }
    states
}

/// Rigid translation of a body in a configuration.
fn shift(model: &Model, state: &AxisState, body: usize) -> [f64; 3] {
    let mut s = [0.0; 3];
    for (ax, &p) in model.axes.iter().zip(&state.positions) {
        if ax.body == body {
            for (sk, dk) in s.iter_mut().zip(ax.direction) {
                *sk += p * dk;
            }
        }
    }
    s
}

/// Location of a named point (no sliding) and its global position in `state`.
fn named(model: &Model, state: &AxisState, end: &End) -> (Location, [f64; 3]) {
    let sh = shift(model, state, end.body);
    match &model.bodies[end.body].kind {
        BodyKind::Rigid { cg, points, .. } => {
            let p = points[&end.point];
            (
                Location::Rigid([p[0] - cg[0], p[1] - cg[1], p[2] - cg[2]]),
                [p[0] + sh[0], p[1] + sh[1], p[2] + sh[2]],
            )
        }
        BodyKind::Fe { fe, points, .. } => {
            let (node, off) = points[&end.point];
            let x = fe.nodes[node].position;
            (
                Location::Node(node, off),
                std::array::from_fn(|k| x[k] + off[k] + sh[k]),
            )
        }
    }
}

/// Location of a joint end, a sensor or an excitation in `state`.
pub(crate) fn locate(model: &Model, state: &AxisState, end: &End) -> Location {
    named(model, state, end).0
}

/// Location of end `b` of joint `j`: follows end `a` if the joint slides.
pub(crate) fn locate_b(model: &Model, state: &AxisState, j: usize, b: &End) -> Location {
    let sliding = model.axes.iter().any(|ax| ax.sliding.contains(&j));
    if !sliding {
        return locate(model, state, b);
    }
    let (_, pa) = named(model, state, &model.joints[j].a);
    let sh = shift(model, state, b.body);
    match &model.bodies[b.body].kind {
        BodyKind::Rigid { cg, .. } => {
            Location::Rigid(std::array::from_fn(|k| pa[k] - cg[k] - sh[k]))
        }
        BodyKind::Fe { fe, points, .. } => {
            let (_, off) = points[&b.point];
            let target = std::array::from_fn(|k| pa[k] - off[k] - sh[k]);
            Location::Node(fe.nearest_node(target), off)
        }
    }
}
