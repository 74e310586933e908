//! A body-fixed point in the global DOFs: its 6 rows (u, θ) through the
//! body's rigid offset or FE node, and the lumped masses placed at points
//! (accelerometers, force gauges: M += m PᵀP, no new DOF).

#![allow(non_snake_case)]

use super::assembly::PreparedBody;
use super::configuration::{locate, AxisState, Location};
use super::model::{BodyKind, Model};
use super::rigid::offset_map;
use faer::Mat;

/// Lumped point masses into the mass triplets: M += m Σ_a P_aᵀ P_a over
/// the translation rows P_a of the mass's point (rigid offset included,
/// so a mass off a beam's axis also adds its m r² about the axis). A named
/// point is body-fixed, so its rows are the same in every configuration.
pub(super) fn point_masses(
    model: &Model,
    bodies: &[PreparedBody],
    n: usize,
    state: &AxisState,
    triplets: &mut Vec<(usize, usize, f64)>,
) {
    for m in &model.masses {
        let P = point_rows(model, bodies, n, m.end.body, locate(model, state, &m.end));
        for &a in &m.axes {
            let row: Vec<(usize, f64)> = (0..n)
                .filter(|&c| P[(a, c)] != 0.0)
                .map(|c| (c, P[(a, c)]))
                .collect();
            for &(i, pi) in &row {
                for &(j, pj) in &row {
                    triplets.push((i, j, m.mass * pi * pj));
                }
            }
        }
    }
}

/// 6 × n rows of a point's (u, θ) in global DOFs.
pub(super) fn point_rows(
    model: &Model,
    bodies: &[PreparedBody],
    n: usize,
    body: usize,
    loc: Location,
) -> Mat<f64> {
    let pb = &bodies[body];
    let mut P = Mat::<f64>::zeros(6, n);
    let local: Mat<f64> = match (&model.bodies[body].kind, loc) {
        (BodyKind::Rigid { dofs, .. }, Location::Rigid(r)) => {
            let T = offset_map(r);
            Mat::from_fn(6, dofs.len(), |i, j| T[i][dofs[j]])
        }
        (BodyKind::Fe { fe, .. }, Location::Node(node, off)) => {
            let full = fe.point_rows(node, off);
            match &pb.T {
                Some(T) => full * T,
                None => full,
            }
        }
        // Locations are produced from the body's own kind.
        _ => Mat::zeros(6, pb.n),
    };
    P.submatrix_mut(0, pb.offset, 6, pb.n).copy_from(&local);
    P
}
