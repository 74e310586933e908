//! Bodies of a model: validation of the rigid, beam and super-element
//! specifications (positive mass, positive definite inertia, positive
//! section properties, finite numbers, existing nodes) and their
//! construction (rigid mass data, assembled beam FE matrices, imported
//! super-element matrices). Errors name the file and the field.
#![allow(non_snake_case)]

use super::beam::{assemble_beam, local_axes, Section};
use super::beam_terms::{stiffness_columns, Column};
use super::error::DynamicsError;
use super::fe_body::FeBody;
use super::model::{parameter_ref, Parameter};
use super::model_file::{
    BeamSpec, BodySpec, NodePointSpec, ParameterKind, RigidSpec, SectionValue,
};
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
        /// Material loss factor η (D_body = η K_body) of the fixed part.
        loss_factor: f64,
        /// Stiffness and material damping that vary with parameters.
        terms: BodyTerms,
    },
}

/// The part of a body's stiffness K and material damping D that varies with
/// parameters: rank-one columns g over the body's DOFs, each with the index
/// p of the parameter that multiplies it (K += x_p g gᵀ, D likewise), the
/// form of joint terms ([`super::beam_terms`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct BodyTerms {
    pub stiffness: Vec<(Column, usize)>,
    pub hysteretic: Vec<(Column, usize)>,
}

impl BodyTerms {
    pub fn is_empty(&self) -> bool {
        self.stiffness.is_empty() && self.hysteretic.is_empty()
    }
}

/// A section value after validation: a number or a parameter (index and
/// the model file's value of it).
#[derive(Debug, Clone, Copy)]
enum Resolved {
    Number(f64),
    Parameter(usize, f64),
}

impl Resolved {
    fn number_or(self, other: f64) -> f64 {
        match self {
            Resolved::Number(x) => x,
            Resolved::Parameter(..) => other,
        }
    }
    fn nominal(self) -> f64 {
        match self {
            Resolved::Number(x) | Resolved::Parameter(_, x) => x,
        }
    }
}

/// Resolve a section value: a number (finite, > 0, or ≥ 0 when
/// `zero_ok`) or the name of a parameter of `kind` (whose lower bound must
/// be > 0 unless `zero_ok`), validated like a joint's parameter reference.
fn resolve(
    v: &SectionValue,
    kind: ParameterKind,
    zero_ok: bool,
    parameters: &[Parameter],
    file: &str,
    field: &str,
) -> Result<Resolved, DynamicsError> {
    match v {
        SectionValue::Number(x) => {
            finite(file, field, &[*x])?;
            if *x < 0.0 || (!zero_ok && *x == 0.0) {
                let need = if zero_ok { ">= 0" } else { "> 0" };
                return Err(DynamicsError::invalid(
                    file,
                    field,
                    format!("must be {need} (SI units), got {x}"),
                ));
            }
            Ok(Resolved::Number(*x))
        }
        SectionValue::Parameter(name) => {
            let i = parameter_ref(parameters, name, kind, file, field)?;
            let p = &parameters[i];
            if !zero_ok && p.lower <= 0.0 {
                return Err(DynamicsError::invalid(
                    file,
                    field,
                    format!("parameter `{name}` needs a lower bound > 0 (a modulus of 0 has no stiffness)"),
                ));
            }
            Ok(Resolved::Parameter(i, p.value))
        }
    }
}

/// A beam body: its fixed matrices (every numeric E, G), the loss factor of
/// the fixed part, and the terms of parameter-valued E, G and loss factor.
/// With a parameter loss factor η the material damping is D = η K(E₀, G₀),
/// K at the model file's values of E and G (exact while E and G are
/// numbers; with both varying, D is off by the factor E/E₀ — a few % for an
/// updated modulus, small against the scatter of measured damping).
fn beam_body(
    bm: &BeamSpec,
    g: &str,
    file: &str,
    parameters: &[Parameter],
    R: [[f64; 3]; 3],
) -> Result<(FeBody, f64, BodyTerms), DynamicsError> {
    let s = &bm.section;
    let field = |n: &str| format!("{g}.section.{n}");
    let geometric = [s.A, s.Iy, s.Iz, s.J, s.rho];
    let numbers = [&s.E, &s.G].into_iter().filter_map(|v| match v {
        SectionValue::Number(x) => Some(*x),
        SectionValue::Parameter(_) => None,
    });
    let all: Vec<f64> = geometric.into_iter().chain(numbers).collect();
    finite(file, &format!("{g}.section"), &all)?;
    if all.iter().any(|&x| x <= 0.0) {
        return Err(DynamicsError::invalid(
            file,
            format!("{g}.section"),
            "A, Iy, Iz, J, E, G, rho must all be positive (SI units)",
        ));
    }
    let E = resolve(
        &s.E,
        ParameterKind::Stiffness,
        false,
        parameters,
        file,
        &field("E"),
    )?;
    let G = resolve(
        &s.G,
        ParameterKind::Stiffness,
        false,
        parameters,
        file,
        &field("G"),
    )?;
    let loss = resolve(
        &bm.loss_factor,
        ParameterKind::Damping,
        true,
        parameters,
        file,
        &format!("{g}.loss_factor"),
    )?;
    let section = |e: f64, gm: f64| Section {
        A: s.A,
        Iy: s.Iy,
        Iz: s.Iz,
        J: s.J,
        E: e,
        G: gm,
        rho: s.rho,
    };
    let fixed = section(E.number_or(0.0), G.number_or(0.0));
    let fe = assemble_beam(bm.start, bm.end, bm.elements, R, &fixed);
    let columns =
        |e: f64, gm: f64| stiffness_columns(bm.start, bm.end, bm.elements, R, &section(e, gm));
    let mut terms = BodyTerms::default();
    for (value, unit) in [(E, (1.0, 0.0)), (G, (0.0, 1.0))] {
        if let Resolved::Parameter(p, _) = value {
            terms
                .stiffness
                .extend(columns(unit.0, unit.1).into_iter().map(|c| (c, p)));
        }
    }
    let eta = match loss {
        Resolved::Number(eta) => {
            // D = η K: the parametric part's columns scaled by √η.
            let r = eta.sqrt();
            terms.hysteretic = terms
                .stiffness
                .iter()
                .filter(|_| eta > 0.0)
                .map(|(c, p)| (c.iter().map(|&(i, v)| (i, r * v)).collect(), *p))
                .collect();
            eta
        }
        Resolved::Parameter(h, _) => {
            let all = columns(E.nominal(), G.nominal());
            terms.hysteretic = all.into_iter().map(|c| (c, h)).collect();
            0.0
        }
    };
    if !terms.is_empty() && bm.reduction.is_some() {
        return Err(DynamicsError::invalid(
            file,
            format!("{g}.reduction"),
            "a beam whose E, G or loss factor is a parameter cannot be Craig–Bampton reduced \
             (its reduction basis would change with the parameter); drop `reduction` or give numbers",
        ));
    }
    Ok((fe, eta, terms))
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

/// The kind of body `b` (field path `f` in `file`): exactly one of a rigid
/// body, a beam or a super-element, validated and built.
pub(crate) fn body_kind(
    b: &BodySpec,
    f: &str,
    file: &str,
    resolver: Resolver<'_>,
    parameters: &[Parameter],
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
        return rigid_body(r, &format!("{f}.rigid"), file);
    }
    let (fe, points, reduction, loss_factor, terms, g) = if let Some(bm) = &b.beam {
        let g = format!("{f}.beam");
        let (fe, eta, terms) = beam_fe(bm, &g, file, parameters)?;
        (fe, &bm.points, &bm.reduction, eta, terms, g)
    } else if let Some(se) = &b.superelement {
        let g = format!("{f}.superelement");
        (
            load_superelement(se, resolver, file, &g)?,
            &se.points,
            &se.reduction,
            se.loss_factor,
            BodyTerms::default(),
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
    let points = node_points(&fe, points, &g, file)?;
    Ok(BodyKind::Fe {
        fe,
        points,
        modes: reduction.as_ref().map(|r| r.modes),
        loss_factor,
        terms,
    })
}

/// A rigid body (field path `g`): finite numbers, positive mass, positive
/// definite inertia and at least one DOF (sorted, without repeats).
fn rigid_body(r: &RigidSpec, g: &str, file: &str) -> Result<BodyKind, DynamicsError> {
    let inv = |field: String, msg: &str| DynamicsError::invalid(file, field, msg);
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
    Ok(BodyKind::Rigid {
        mass: r.mass,
        inertia: r.inertia,
        cg: r.cg,
        points: r.points.clone(),
        dofs,
    })
}

/// A beam body (field path `g`) after checking its geometry, element count
/// against the memory limit and orientation: [`beam_body`]'s matrices,
/// loss factor and parameter terms.
fn beam_fe(
    bm: &BeamSpec,
    g: &str,
    file: &str,
    parameters: &[Parameter],
) -> Result<(FeBody, f64, BodyTerms), DynamicsError> {
    let inv = |field: String, msg: &str| DynamicsError::invalid(file, field, msg);
    finite(file, g, &[bm.start, bm.end, bm.orientation].concat())?;
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
    beam_body(bm, g, file, parameters, R)
}

/// The named points of an FE body (field path `g`) as (node index,
/// offset): the node must exist, and only a node with rotations can carry
/// a rigid offset.
fn node_points(
    fe: &FeBody,
    points: &BTreeMap<String, NodePointSpec>,
    g: &str,
    file: &str,
) -> Result<BTreeMap<String, (usize, [f64; 3])>, DynamicsError> {
    let inv = |field: String, msg: &str| DynamicsError::invalid(file, field, msg);
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
    Ok(pts)
}
