//! Mode shapes drawn on the structure: each mode deformed (colour) over
//! the undeformed geometry (grey) in three orthographic views: with the
//! model's vertical axis given (evaluate's `vertical`, else the model
//! file's `vertical:`), top (looking down
//! it), front and side (it drawn upward) — a y-up model's top looks down
//! y —, else named by plane and viewing axis (`x–y (along z)`, …), and
//! animated between ±amplitude with SMIL
//! `<animate>` (browsers play it in the HTML report; a still renderer shows
//! the +amplitude frame). Identified and reference modes of a pair stand
//! side by side with their frequencies and MAC.
//!
//! A complex shape is first rotated to its most real form (the phase that
//! maximizes Σ Re(φ)²: α = −½·arg Σ φ²), then its real part is drawn;
//! node displacements are Σ over the node's measured directions (±X, ±Y,
//! ±Z; rotations are not drawn), scaled so the largest is 12 % of the
//! structure's size. Nodes without a measured DOF stay where they are.
//!
//! The modes of one row (a reference and its partner) are sign-aligned:
//! a later mode whose displacements point against the first one's
//! (Σ u₁·uₖ < 0 over their nodes) is drawn negated, as MAC ignores the
//! sign. A view in which the structure collapses to a point (a collinear
//! structure seen along its line) is left out, and nodes without trace
//! lines that lie on one line are joined in order, so a beam of sensors
//! is drawn as a line, not as dots.

use super::style::{text_width, FONT, LABEL_SIZE, TICK_SIZE, TITLE_SIZE};
use super::svg::{esc, header};
use crate::geometry::Geometry;
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;
use std::collections::BTreeMap;
use std::fmt::Write;

/// Side of one view in px.
const VIEW: f64 = 130.0;
/// Animation period.
const PERIOD_S: f64 = 1.6;

/// A view: its name, and the model axes drawn horizontally and upward.
type View = (String, usize, usize);

const AXES: [&str; 3] = ["x", "y", "z"];

/// The three views. With the model's `vertical` axis v and the others
/// h₁ < h₂: top (h₁–h₂, looking down v), front (h₁ across, v up) and side
/// (h₂ across, v up) — a y-up model's top looks down y. Without it, the
/// planes x–y, x–z, y–z named by the axis they look along.
fn all_views(vertical: Option<usize>) -> [View; 3] {
    match vertical {
        Some(v) if v < 3 => {
            let [h1, h2] = match v {
                0 => [1, 2],
                1 => [0, 2],
                _ => [0, 1],
            };
            let (a, b, up) = (AXES[h1], AXES[h2], AXES[v]);
            [
                (format!("top {a}–{b} (down {up})"), h1, h2),
                (format!("front {a}–{up} ({up} up)"), h1, v),
                (format!("side {b}–{up} ({up} up)"), h2, v),
            ]
        }
        _ => [
            ("x–y (along z)".into(), 0, 1),
            ("x–z (along y)".into(), 0, 2),
            ("y–z (along x)".into(), 1, 2),
        ],
    }
}

/// The views in which the structure is more than a point (all three when
/// every one collapses, e.g. a single node).
fn views(g: &Geometry, vertical: Option<usize>) -> Vec<View> {
    let (lo, hi, size) = extent(g);
    let flat = |k: usize| hi[k] - lo[k] <= 1e-3 * size;
    let all = all_views(vertical);
    let kept: Vec<View> = all
        .iter()
        .filter(|v| !(flat(v.1) && flat(v.2)))
        .cloned()
        .collect();
    if kept.is_empty() {
        all.to_vec()
    } else {
        kept
    }
}

/// The trace lines to draw: the geometry's, or, when it has none and its
/// nodes lie on one line, the nodes joined in order along that line.
fn trace_lines(g: &Geometry) -> Vec<(u32, u32)> {
    if !g.lines.is_empty() || g.nodes.len() < 2 {
        return g.lines.clone();
    }
    let (lo, hi, size) = extent(g);
    let first = g.nodes[0].xyz;
    let last = g
        .nodes
        .iter()
        .map(|n| n.xyz)
        .max_by(|a, b| dist(*a, first).total_cmp(&dist(*b, first)))
        .unwrap_or(first);
    let axis = [last[0] - first[0], last[1] - first[1], last[2] - first[2]];
    let len = dist(last, first);
    if len <= 0.0 || hi.iter().zip(&lo).all(|(h, l)| h - l <= 0.0) {
        return Vec::new();
    }
    let along = |p: [f64; 3]| (0..3).map(|k| (p[k] - first[k]) * axis[k]).sum::<f64>() / len;
    // Collinear: every node within 1 % of the size off the line.
    let off = |p: [f64; 3]| {
        let t = along(p) / len;
        dist(p, [0, 1, 2].map(|k| first[k] + t * axis[k]))
    };
    if g.nodes.iter().any(|n| off(n.xyz) > 0.01 * size) {
        return Vec::new();
    }
    let mut order: Vec<(f64, u32)> = g.nodes.iter().map(|n| (along(n.xyz), n.id)).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    order.windows(2).map(|w| (w[0].1, w[1].1)).collect()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// `d` negated when it points against `reference` over their nodes.
fn align(d: &mut Deflection, reference: &Deflection) {
    let dot: f64 = d
        .by_node
        .iter()
        .filter_map(|(id, u)| {
            let r = reference.by_node.get(id)?;
            Some(u[0] * r[0] + u[1] * r[1] + u[2] * r[2])
        })
        .sum();
    if dot < 0.0 {
        for u in d.by_node.values_mut() {
            *u = u.map(|x| -x);
        }
    }
}

/// One drawn mode: its displacement per node.
struct Deflection {
    by_node: BTreeMap<u32, [f64; 3]>,
}

fn deflection(model: &ModalModel, mode: &Mode) -> Deflection {
    let s: Complex64 = mode.shape.iter().map(|v| v * v).sum();
    let rot = Complex64::from_polar(1.0, -0.5 * s.arg());
    let mut by_node: BTreeMap<u32, [f64; 3]> = BTreeMap::new();
    for (dof, v) in model.dofs.iter().zip(&mode.shape) {
        let axis = dof.direction.unsigned_abs();
        if !(1..=3).contains(&axis) {
            continue;
        }
        let sign = if dof.direction < 0 { -1.0 } else { 1.0 };
        by_node.entry(dof.node).or_insert([0.0; 3])[usize::from(axis) - 1] += sign * (v * rot).re;
    }
    Deflection { by_node }
}

/// A mode to draw with its heading.
pub struct Drawn<'a> {
    pub model: &'a ModalModel,
    pub mode: usize,
    pub heading: String,
}

/// Bounding box of the geometry: (min, max, size).
fn extent(g: &Geometry) -> ([f64; 3], [f64; 3], f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for n in &g.nodes {
        for k in 0..3 {
            lo[k] = lo[k].min(n.xyz[k]);
            hi[k] = hi[k].max(n.xyz[k]);
        }
    }
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    (lo, hi, if size > 0.0 { size } else { 1.0 })
}

/// One view of one mode at (x0, y0).
fn view(
    s: &mut String,
    g: &Geometry,
    lines: &[(u32, u32)],
    d: &Deflection,
    (x0, y0): (f64, f64),
    v: &View,
    colour: &str,
) {
    let (lo, hi, size) = extent(g);
    let (h_axis, v_axis) = (v.1, v.2);
    let pad = 0.18 * size;
    let span = size + 2.0 * pad;
    let scale = VIEW / span;
    // Centre the structure in the view.
    let cx = 0.5 * (lo[h_axis] + hi[h_axis]);
    let cy = 0.5 * (lo[v_axis] + hi[v_axis]);
    let px = |p: [f64; 3]| x0 + VIEW / 2.0 + (p[h_axis] - cx) * scale;
    let py = |p: [f64; 3]| y0 + VIEW / 2.0 - (p[v_axis] - cy) * scale;
    let max_d = d
        .by_node
        .values()
        .map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
        .fold(0.0, f64::max);
    let amp = if max_d > 0.0 {
        0.12 * size / max_d
    } else {
        0.0
    };
    let coords = g.coordinates();
    let moved = |id: u32, sign: f64| -> Option<[f64; 3]> {
        let p = *coords.get(&id)?;
        let u = d.by_node.get(&id).copied().unwrap_or([0.0; 3]);
        Some([0, 1, 2].map(|k| p[k] + sign * amp * u[k]))
    };
    let _ = write!(
        s,
        r##"<rect x="{x0:.1}" y="{y0:.1}" width="{VIEW}" height="{VIEW}" fill="#fafafa" stroke="#ccc"/><text x="{:.1}" y="{:.1}" font-size="10" fill="#666">{}</text>"##,
        x0 + 3.0,
        y0 + 11.0,
        v.0
    );
    let anim = |attr: &str, a: f64, b: f64| {
        format!(
            r#"<animate attributeName="{attr}" values="{a:.1};{b:.1};{a:.1}" dur="{PERIOD_S}s" repeatCount="indefinite"/>"#
        )
    };
    for &(a, b) in lines {
        let (Some(p), Some(q)) = (coords.get(&a), coords.get(&b)) else {
            continue;
        };
        let _ = write!(
            s,
            r##"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#bbb" stroke-width="1"/>"##,
            px(*p),
            py(*p),
            px(*q),
            py(*q)
        );
    }
    for &(a, b) in lines {
        let (Some(p), Some(q), Some(pm), Some(qm)) =
            (moved(a, 1.0), moved(b, 1.0), moved(a, -1.0), moved(b, -1.0))
        else {
            continue;
        };
        let _ = write!(
            s,
            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{colour}" stroke-width="1.8">{}{}{}{}</line>"#,
            px(p),
            py(p),
            px(q),
            py(q),
            anim("x1", px(p), px(pm)),
            anim("y1", py(p), py(pm)),
            anim("x2", px(q), px(qm)),
            anim("y2", py(q), py(qm)),
        );
    }
    for n in &g.nodes {
        let (Some(p), Some(m)) = (moved(n.id, 1.0), moved(n.id, -1.0)) else {
            continue;
        };
        let _ = write!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="1.8" fill="#bbb"/><circle cx="{:.1}" cy="{:.1}" r="2.6" fill="{colour}"><title>node {}</title>{}{}</circle>"##,
            px(n.xyz),
            py(n.xyz),
            px(p),
            py(p),
            n.id,
            anim("cx", px(p), px(m)),
            anim("cy", py(p), py(m)),
        );
    }
}

/// Rows of modes, each row its modes side by side in three views each, with
/// a heading over each mode and a note per row (e.g. the pair's MAC).
pub fn figure(
    title: &str,
    caption: &str,
    geometry: &Geometry,
    vertical: Option<usize>,
    rows: &[(Vec<Drawn<'_>>, String)],
) -> String {
    let colours = ["#0072B2", "#D55E00"];
    let gap = 10.0;
    let views = views(geometry, vertical);
    let lines = trace_lines(geometry);
    let nv = views.len() as f64;
    let per_mode = nv * VIEW + (nv - 1.0) * 6.0;
    let cols = rows.iter().map(|r| r.0.len()).max().unwrap_or(1) as f64;
    let note_w = rows
        .iter()
        .map(|r| text_width(&r.1, TICK_SIZE))
        .fold(0.0, f64::max);
    let w =
        (20.0 + cols * (per_mode + gap) + note_w + 10.0).max(text_width(title, TITLE_SIZE) + 24.0);
    let row_h = VIEW + LABEL_SIZE + 14.0;
    let h = 40.0 + rows.len() as f64 * (row_h + gap) + 4.0;
    let mut s = header(w, h, caption);
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    for (r, (modes, note)) in rows.iter().enumerate() {
        let y = 40.0 + r as f64 * (row_h + gap);
        let mut x = 10.0;
        let mut first: Option<Deflection> = None;
        for (k, m) in modes.iter().enumerate() {
            let _ = write!(
                s,
                r#"<text x="{x:.1}" y="{:.1}" font-size="{LABEL_SIZE}" font-family="{FONT}">{}</text>"#,
                y + LABEL_SIZE,
                esc(&m.heading)
            );
            let Some(mode) = m.model.modes.get(m.mode) else {
                continue;
            };
            let mut d = deflection(m.model, mode);
            match &first {
                Some(f) => align(&mut d, f),
                None => first = Some(deflection(m.model, mode)),
            }
            for (i, v) in views.iter().enumerate() {
                view(
                    &mut s,
                    geometry,
                    &lines,
                    &d,
                    (x + i as f64 * (VIEW + 6.0), y + LABEL_SIZE + 6.0),
                    v,
                    colours[k % 2],
                );
            }
            x += per_mode + gap;
        }
        let _ = write!(
            s,
            r#"<text x="{x:.1}" y="{:.1}" font-size="{TICK_SIZE}" font-weight="bold">{}</text>"#,
            y + LABEL_SIZE + 6.0 + VIEW / 2.0,
            esc(note)
        );
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{Dof, Position};
    use crate::geometry::Node;

    #[test]
    fn deformed_nodes_move_by_their_shape_and_stay_in_view() {
        let g = Geometry {
            nodes: (1..=3)
                .map(|i| Node {
                    id: i,
                    xyz: [0.1 * f64::from(i), 0.0, 0.0],
                })
                .collect(),
            lines: vec![(1, 2), (2, 3)],
        };
        let model = ModalModel {
            position: Position::default(),
            dofs: (1..=3).map(|i| Dof::new(i, 1)).collect(),
            modes: vec![Mode {
                frequency_hz: 10.0,
                damping_ratio: 0.01,
                // A complex shape of one phase: drawn as its real form.
                shape: [0.3, 0.6, -0.2]
                    .iter()
                    .map(|&v| Complex64::from_polar(v, 0.7))
                    .collect(),
            }],
        };
        let d = deflection(&model, &model.modes[0]);
        let u2 = d.by_node[&2][0];
        assert!((u2.abs() - 0.6).abs() < 1e-12, "{u2}");
        assert_eq!(d.by_node[&2][1], 0.0);
        let svg = figure(
            "Mode shapes",
            "caption",
            &g,
            None,
            &[(
                vec![Drawn {
                    model: &model,
                    mode: 0,
                    heading: "reference 1 · 10.00 Hz".into(),
                }],
                "MAC 1.000".into(),
            )],
        );
        // Collinear along x: the view along x is left out (a point).
        assert_eq!(svg.matches("<animate").count(), 2 * (2 * 4 + 3 * 2));
        assert!(!svg.contains("y–z (along x)") && svg.contains("x–y (along z)"));
        let problems = super::super::lint::check(&svg);
        assert!(problems.is_empty(), "{problems:?}");
    }

    #[test]
    fn partners_are_sign_aligned_and_collinear_nodes_joined() {
        let g = Geometry {
            nodes: (1..=3)
                .map(|i| Node {
                    id: i,
                    xyz: [0.0, 0.5 * f64::from(i), 0.0],
                })
                .collect(),
            lines: Vec::new(),
        };
        assert_eq!(trace_lines(&g), [(1, 2), (2, 3)]);
        let model = |sign: f64| ModalModel {
            position: Position::default(),
            dofs: (1..=3).map(|i| Dof::new(i, 3)).collect(),
            modes: vec![Mode {
                frequency_hz: 10.0,
                damping_ratio: 0.01,
                shape: [0.3, 1.0, 0.3]
                    .iter()
                    .map(|&v| Complex64::new(sign * v, 0.0))
                    .collect(),
            }],
        };
        let (a, b) = (model(1.0), model(-1.0));
        let r = deflection(&a, &a.modes[0]);
        let mut d = deflection(&b, &b.modes[0]);
        assert!(d.by_node[&2][2] * r.by_node[&2][2] < 0.0);
        align(&mut d, &r);
        assert!(
            d.by_node[&2][2] * r.by_node[&2][2] > 0.0,
            "flipped to match"
        );
        let drawn = |m| Drawn {
            model: m,
            mode: 0,
            heading: "mode".into(),
        };
        let svg = figure(
            "Shapes",
            "c",
            &g,
            None,
            &[(vec![drawn(&a), drawn(&b)], "MAC 1".into())],
        );
        // Both partners' deformed lines identical once aligned.
        let deformed: Vec<&str> = svg
            .split("stroke-width=\"1.8\">")
            .skip(1)
            .map(|p| p.split("</line>").next().unwrap_or_default())
            .collect();
        assert_eq!(deformed.len(), 2 * 2 * 2, "2 lines × 2 views × 2 modes");
        // The view along z shows z motion vertically: same y animation.
        let y1 = |line: &str| {
            let i = line.find("attributeName=\"y1\"").unwrap_or(0);
            line[i..].split("/>").next().unwrap_or_default().to_string()
        };
        assert_eq!(
            y1(deformed[2]),
            y1(deformed[6]),
            "same motion after alignment"
        );
        assert!(y1(deformed[2]).contains(';'));
    }

    #[test]
    fn views_follow_the_vertical_axis() {
        let names = |v: Option<usize>| all_views(v).map(|x| x.0);
        // A y-up model: top looks down y (x–z), front and side draw y up.
        let y_up = all_views(Some(1));
        assert_eq!(y_up[0], ("top x–z (down y)".to_string(), 0, 2));
        assert_eq!(y_up[1], ("front x–y (y up)".to_string(), 0, 1));
        assert_eq!(y_up[2], ("side z–y (y up)".to_string(), 2, 1));
        assert_eq!(names(Some(2))[0], "top x–y (down z)");
        assert_eq!(names(None)[0], "x–y (along z)");
    }
}
