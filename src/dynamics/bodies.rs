//! Bodies of a model: validation of the rigid, beam and super-element
//! specifications (positive mass, positive definite inertia, positive
//! section properties, finite numbers, existing nodes) and their
//! construction (rigid mass data, assembled beam FE matrices, imported
//! super-element matrices). Errors name the file and the field.
#![allow(non_snake_case)]

use super::beam::{assemble_beam, local_axes};
use super::error::DynamicsError;
use super::fe_body::FeBody;
use super::model_file::BodySpec;
use super::rigid::inertia_is_positive_definite;
use super::superelement::{load_superelement, Resolver};
use std::collections::BTreeMap;

/// Geometry and inertia of one body.
#[derive(Debug, Clone)]
pub(crate) enum BodyKind {
    Rigid {
        mass: f64,
        inertia: [[f64; 3]; 3],
        cg: [f64; 3],
        points: BTreeMap<String, [f64; 3]>,
        dofs: Vec<usize>,
    },
    Fe {
        fe: FeBody,
        points: BTreeMap<String, (usize, [f64; 3])>,
        modes: Option<usize>,
        /// Material loss factor η (D_body = η K_body).
        loss_factor: f64,
    },
}

#[derive(Debug, Clone)]
pub(crate) struct Body {
    pub name: String,
    pub kind: BodyKind,
}

pub(crate) fn finite(file: &str, field: &str, v: &[f64]) -> Result<(), DynamicsError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(DynamicsError::invalid(
            file,
            field,
            "must be a finite number (NaN/inf given)",
        ))
    }
}

pub(crate) fn body_kind(
    b: &BodySpec,
    f: &str,
    file: &str,
    resolver: Resolver<'_>,
) -> Result<BodyKind, DynamicsError> {
    let inv = |field: String, msg: &str| DynamicsError::invalid(file, field, msg);
    let count = b.rigid.is_some() as u8 + b.beam.is_some() as u8 + b.superelement.is_some() as u8;
    if count != 1 {
        return Err(inv(
            f.to_string(),
            "give exactly one of `rigid`, `beam`, `superelement`",
        ));
    }
    if let Some(r) = &b.rigid {
        let g = format!("{f}.rigid");
        finite(file, &format!("{g}.mass"), &[r.mass])?;
        finite(file, &format!("{g}.inertia"), r.inertia.as_flattened())?;
        finite(file, &format!("{g}.cg"), &r.cg)?;
        if r.mass <= 0.0 {
            return Err(inv(format!("{g}.mass"), "must be positive (kg)"));
        }
        if !inertia_is_positive_definite(&r.inertia) {
            return Err(inv(
                format!("{g}.inertia"),
                "must be a positive definite tensor (kg·m²) about the centre of gravity",
            ));
        }
        for (name, p) in &r.points {
            finite(file, &format!("{g}.points.{name}"), p)?;
        }
        let mut dofs: Vec<usize> = match &r.dofs {
            Some(d) => d.iter().map(|d| d.index()).collect(),
            None => (0..6).collect(),
        };
        dofs.sort_unstable();
        dofs.dedup();
        if dofs.is_empty() {
            return Err(inv(format!("{g}.dofs"), "list at least one DOF"));
        }
        return Ok(BodyKind::Rigid {
            mass: r.mass,
            inertia: r.inertia,
            cg: r.cg,
            points: r.points.clone(),
            dofs,
        });
    }
    let (fe, points, reduction, loss_factor, g) = if let Some(bm) = &b.beam {
        let g = format!("{f}.beam");
        finite(file, &g, &[bm.start, bm.end, bm.orientation].concat())?;
        let s = bm.section;
        let sec = [s.A, s.Iy, s.Iz, s.J, s.E, s.G, s.rho];
        finite(file, &format!("{g}.section"), &sec)?;
        if sec.iter().any(|&x| x <= 0.0) {
            return Err(inv(
                format!("{g}.section"),
                "A, Iy, Iz, J, E, G, rho must all be positive (SI units)",
            ));
        }
        if bm.elements == 0 {
            return Err(inv(format!("{g}.elements"), "need at least one element"));
        }
        // The beam is assembled sparse: 2 × 144 triplets per element (24
        // bytes each) before compression; bound them by the memory limit
        // before allocating (found by the fuzz harness).
        let n = 6.0 * (bm.elements as f64 + 1.0);
        let bytes = 2.0 * 144.0 * 24.0 * bm.elements as f64;
        let limit = crate::resources::memory_limit() as f64;
        if bytes > limit {
            return Err(inv(
                format!("{g}.elements"),
                &format!(
                    "{} elements make {n} DOF whose matrices need an estimated {}, more than \
                     the limit of {} (--max-memory); use fewer elements",
                    bm.elements,
                    crate::resources::human(bytes),
                    crate::resources::human(limit)
                ),
            ));
        }
        let R = local_axes(bm.start, bm.end, bm.orientation).ok_or_else(|| {
            inv(
                format!("{g}.orientation"),
                "beam has zero length or orientation is parallel to its axis",
            )
        })?;
        (
            assemble_beam(bm.start, bm.end, bm.elements, R, &s),
            &bm.points,
            &bm.reduction,
            bm.loss_factor,
            g,
        )
    } else if let Some(se) = &b.superelement {
        let g = format!("{f}.superelement");
        (
            load_superelement(se, resolver, file, &g)?,
            &se.points,
            &se.reduction,
            se.loss_factor,
            g,
        )
    } else {
        return Err(inv(
            f.to_string(),
            "give exactly one of `rigid`, `beam`, `superelement`",
        ));
    };
    if !(loss_factor.is_finite() && loss_factor >= 0.0) {
        return Err(inv(
            format!("{g}.loss_factor"),
            "must be a finite number >= 0 (typically 0.001-0.005 for metals)",
        ));
    }
    let mut pts = BTreeMap::new();
    for (name, p) in points {
        let pf = format!("{g}.points.{name}");
        finite(file, &pf, &p.offset)?;
        let idx = fe
            .node_index(p.node)
            .ok_or_else(|| inv(format!("{pf}.node"), "no such node"))?;
        let has_rot = fe.nodes[idx].dofs[3..].iter().all(|d| d.is_some());
        if !has_rot && p.offset.iter().any(|&x| x != 0.0) {
            return Err(inv(
                format!("{pf}.offset"),
                "a translational-only node cannot carry a rigid offset",
            ));
        }
        pts.insert(name.clone(), (idx, p.offset));
    }
    Ok(BodyKind::Fe {
        fe,
        points: pts,
        modes: reduction.as_ref().map(|r| r.modes),
        loss_factor,
    })
}
