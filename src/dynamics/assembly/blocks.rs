//! The body part of the assembly ([`super`]): which FE nodes the joints,
//! sensors, excitations and point masses use (the Craig–Bampton boundary),
//! each body's matrices in the global DOF vector (rigid mass data,
//! Craig–Bampton reductions, unreduced sparse FE matrices), and their
//! triplets for the global M, K₀ and material damping D₀ = η K₀.
#![allow(non_snake_case)]

use super::PreparedBody;
use crate::dynamics::configuration::{locate, locate_b, AxisState, Location};
use crate::dynamics::craig_bampton::craig_bampton;
use crate::dynamics::error::DynamicsError;
use crate::dynamics::model::{BodyKind, End, Model};
use crate::dynamics::rigid::rigid_mass;
use crate::dynamics::sparse::Csc;
use faer::Mat;
use std::collections::BTreeSet;

const AXES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

/// Nodes of each FE body used anywhere (by a joint, a sensor, an
/// excitation or a point mass, in any configuration `states`): the
/// Craig–Bampton boundary.
pub(super) fn boundary_nodes(model: &Model, states: &[AxisState]) -> Vec<BTreeSet<usize>> {
    // Nodes of each FE body used anywhere → Craig-Bampton boundary.
    let mut used: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); model.bodies.len()];
    let mut mark = |end: &End, loc: Location| {
        if let Location::Node(n, _) = loc {
            used[end.body].insert(n);
        }
    };
    for st in states {
        for (ji, j) in model.joints.iter().enumerate() {
            mark(&j.a, locate(model, st, &j.a));
            if let Some(b) = &j.b {
                mark(b, locate_b(model, st, ji, b));
            }
        }
        for p in model.sensors.iter().chain(&model.excitations) {
            mark(&p.end, locate(model, st, &p.end));
        }
        for m in &model.masses {
            mark(&m.end, locate(model, st, &m.end));
        }
    }
    used
}

/// Every body's place in the global DOF vector and its matrices.
pub(super) struct BodyBlocks {
    pub(super) bodies: Vec<PreparedBody>,
    /// Matrices and material loss factor η of each body.
    pub(super) blocks: Vec<(Block, f64)>,
    /// Label of every global DOF.
    pub(super) dof_labels: Vec<String>,
    /// Number of global DOFs.
    pub(super) n: usize,
}

/// The bodies of `model` one after the other in the global DOF vector,
/// each reduced on its boundary nodes `used` if it asks for Craig–Bampton.
pub(super) fn body_blocks(
    model: &Model,
    used: &[BTreeSet<usize>],
) -> Result<BodyBlocks, DynamicsError> {
    let mut bodies = Vec::new();
    let mut blocks: Vec<(Block, f64)> = Vec::new();
    let mut dof_labels = Vec::new();
    let mut offset = 0;
    for (bi, body) in model.bodies.iter().enumerate() {
        let (block, eta, T) = body_block(body, &used[bi], &mut dof_labels)?;
        let n = match &block {
            Block::Dense(M, _) => M.nrows(),
            Block::Sparse(M, _) => M.n,
        };
        bodies.push(PreparedBody { offset, n, T });
        blocks.push((block, eta));
        offset += n;
    }
    Ok(BodyBlocks {
        bodies,
        blocks,
        dof_labels,
        n: offset,
    })
}

/// Triplets of the block-diagonal body mass M, stiffness K₀ and material
/// damping D₀ = η K₀ (bodies with η > 0 only), in the global DOF vector.
pub(super) fn body_triplets(
    bodies: &[PreparedBody],
    blocks: &[(Block, f64)],
) -> [Vec<(usize, usize, f64)>; 3] {
    let (mut tm, mut tk, mut td) = (Vec::new(), Vec::new(), Vec::new());
    for (b, (block, eta)) in bodies.iter().zip(blocks) {
        match block {
            Block::Dense(Mb, Kb) => {
                Csc::dense_triplets(Mb, b.offset, &mut tm);
                Csc::dense_triplets(Kb, b.offset, &mut tk);
                if *eta > 0.0 {
                    Csc::dense_triplets(&(Kb * faer::Scale(*eta)), b.offset, &mut td);
                }
            }
            Block::Sparse(Mb, Kb) => {
                Mb.triplets(b.offset, 1.0, &mut tm);
                Kb.triplets(b.offset, 1.0, &mut tk);
                if *eta > 0.0 {
                    Kb.triplets(b.offset, *eta, &mut td);
                }
            }
        }
    }
    [tm, tk, td]
}

/// One body's matrices: dense after a Craig–Bampton reduction or for a
/// rigid body, sparse for an unreduced FE body.
pub(super) enum Block {
    Dense(Mat<f64>, Mat<f64>),
    Sparse(Csc, Csc),
}

/// The matrices of one body (reduced if it asks for Craig–Bampton), its
/// material loss factor and full → reduced map; appends its DOF labels.
fn body_block(
    body: &crate::dynamics::model::Body,
    used: &BTreeSet<usize>,
    dof_labels: &mut Vec<String>,
) -> Result<(Block, f64, Option<Mat<f64>>), DynamicsError> {
    let eta = match &body.kind {
        BodyKind::Fe { loss_factor, .. } => *loss_factor,
        BodyKind::Rigid { .. } => 0.0,
    };
    Ok(match &body.kind {
        BodyKind::Rigid {
            mass,
            inertia,
            dofs,
            ..
        } => {
            dof_labels.extend(dofs.iter().map(|&a| format!("{}.{}", body.name, AXES[a])));
            let full = rigid_mass(*mass, inertia);
            let n = dofs.len();
            (
                Block::Dense(
                    Mat::from_fn(n, n, |i, j| full[(dofs[i], dofs[j])]),
                    Mat::zeros(n, n),
                ),
                eta,
                None,
            )
        }
        BodyKind::Fe {
            fe, modes: Some(q), ..
        } => {
            let boundary: Vec<usize> = used.iter().flat_map(|&n| fe.node_dofs(n)).collect();
            for &n in used {
                let id = fe.nodes[n].id;
                for (j, d) in fe.nodes[n].dofs.iter().enumerate() {
                    if d.is_some() {
                        dof_labels.push(format!("{}.node{id}.{}", body.name, AXES[j]));
                    }
                }
            }
            // Craig–Bampton works on dense matrices: bound them first.
            let nf = fe.n() as f64;
            let bytes = 8.0 * 4.0 * nf * nf;
            let limit = crate::resources::memory_limit() as f64;
            if bytes > limit {
                return Err(DynamicsError::Reduction {
                    body: body.name.clone(),
                    message: format!(
                        "the Craig–Bampton reduction of {nf} DOF needs an estimated {} held dense, \
                         more than the limit of {} (--max-memory); drop the reduction (sparse solver)",
                        crate::resources::human(bytes),
                        crate::resources::human(limit)
                    ),
                });
            }
            let r = craig_bampton(
                &fe.K.to_dense(),
                &fe.M.to_dense(),
                &boundary,
                *q,
                &body.name,
            )?;
            let nq = r.M.nrows() - boundary.len();
            dof_labels.extend((0..nq).map(|i| format!("{}.cb{i}", body.name)));
            (Block::Dense(r.M, r.K), eta, Some(r.T))
        }
        BodyKind::Fe {
            fe, modes: None, ..
        } => {
            let mut labels: Vec<String> = (0..fe.n())
                .map(|i| format!("{}.row{i}", body.name))
                .collect();
            for node in &fe.nodes {
                for (j, d) in node.dofs.iter().enumerate() {
                    if let Some(d) = d {
                        labels[*d] = format!("{}.node{}.{}", body.name, node.id, AXES[j]);
                    }
                }
            }
            dof_labels.extend(labels);
            (Block::Sparse(fe.M.clone(), fe.K.clone()), eta, None)
        }
    })
}
