//! The stabilization diagram as analysts read it, as a self-contained SVG
//! written as text: poles over model order, one symbol per stability class
//! ([`PoleClass`]: new ○, frequency +, frequency and damping □, frequency
//! and vector △, all three ●), the selected modes as red lines with their
//! representative pole ringed (×m at a repeated root), roots rejected by
//! validation as grey ticks at the top, and under it all the CMIF curves
//! (singular values of the FRF matrix per line, log scale; one curve per
//! reference, so a repeated root shows as two curves peaking together).
//! One panel per position.
//!
//! Drawn here, beside the other figures and the style guide, so the
//! numerical core (`crate::ema`) never reaches the report.

use crate::ema::{AutoEmaResult, FrfData, PoleClass};
use std::fmt::Write;

/// One position's panel content.
pub struct Panel<'a> {
    pub title: String,
    pub data: &'a FrfData,
    pub result: &'a AutoEmaResult,
}

const CMIF_COLORS: [&str; 4] = ["#1f77b4", "#9467bd", "#17becf", "#8c564b"];

/// SVG of one pole symbol of `class` at (x, y); None for unphysical poles.
fn symbol(class: PoleClass, x: f64, y: f64) -> Option<String> {
    Some(match class {
        PoleClass::Unphysical => return None,
        PoleClass::New => {
            format!(r##"<circle cx="{x:.1}" cy="{y:.1}" r="1.6" fill="none" stroke="#bbb"/>"##)
        }
        PoleClass::Frequency => format!(
            r##"<path d="M{:.1} {y:.1}h5M{x:.1} {:.1}v5" stroke="#999" stroke-width="1"/>"##,
            x - 2.5,
            y - 2.5
        ),
        PoleClass::Damping => format!(
            r##"<rect x="{:.1}" y="{:.1}" width="4.4" height="4.4" fill="none" stroke="#ff7f0e"/>"##,
            x - 2.2,
            y - 2.2
        ),
        PoleClass::Vector => format!(
            r##"<path d="M{x:.1} {:.1}l2.6 4.6h-5.2z" fill="none" stroke="#1f77b4"/>"##,
            y - 3.0
        ),
        PoleClass::Stable => {
            format!(r##"<circle cx="{x:.1}" cy="{y:.1}" r="2.4" fill="#2ca02c"/>"##)
        }
    })
}

const W: f64 = 900.0;
const PANEL_H: f64 = 460.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 830.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 370.0;

/// Ticks at 1, 2 or 5 times a power of ten covering [lo, hi].
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let range = (hi - lo).max(1e-12);
    let raw = range / 6.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| range / s <= 8.0)
        .unwrap_or(10.0 * p);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * range {
        out.push(t);
        t += step;
    }
    out
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The diagram of all panels as one SVG document.
pub fn render(panels: &[Panel]) -> String {
    let h = PANEL_H * panels.len().max(1) as f64;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>"#
    );
    for (k, p) in panels.iter().enumerate() {
        let _ = writeln!(s, r#"<g transform="translate(0,{})">"#, k as f64 * PANEL_H);
        panel(&mut s, p);
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n");
    s
}

/// The axes of a panel: frequency (x), model order (left y) and CMIF
/// magnitude in decades (right y).
struct Scales {
    /// Band of the data (Hz).
    f: (f64, f64),
    /// Highest model order.
    n_max: f64,
    /// CMIF decades shown (log10).
    m: (f64, f64),
}

impl Scales {
    /// The x of frequency `v` (Hz).
    fn x(&self, v: f64) -> f64 {
        LEFT + (v - self.f.0) / (self.f.1 - self.f.0).max(1e-12) * (RIGHT - LEFT)
    }
    /// The y of model order `n`.
    fn y_order(&self, n: f64) -> f64 {
        BOTTOM - n / self.n_max * (BOTTOM - TOP)
    }
    /// The y of CMIF magnitude `v` (log10), clamped to the frame.
    fn y_mag(&self, v: f64) -> f64 {
        BOTTOM - ((v - self.m.0) / (self.m.1 - self.m.0)).clamp(0.0, 1.0) * (BOTTOM - TOP)
    }
}

/// The CMIF curves in log10, and the scales of the panel: the data's band,
/// the highest order, and the decades from the top three of the first
/// curve.
fn scales(p: &Panel) -> (Scales, Vec<Vec<f64>>) {
    let f = &p.data.frequencies_hz;
    let (f_lo, f_hi) = (
        f.first().copied().unwrap_or(0.0),
        f.last().copied().unwrap_or(1.0),
    );
    let r = p.result;
    let n_max = r.orders.last().map_or(1, |o| o.order).max(1) as f64;
    let logs: Vec<Vec<f64>> = r
        .cmif
        .iter()
        .map(|c| c.iter().map(|v| v.max(1e-300).log10()).collect())
        .collect();
    let first = logs.first().map(Vec::as_slice).unwrap_or(&[]);
    let (m_lo, m_hi) = logs
        .iter()
        .flatten()
        .filter(|v| v.is_finite() && **v > -299.0)
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    // The top three decades of the first curve and whatever the others reach in them.
    let top = first.iter().cloned().fold(f64::MIN, f64::max);
    let m_lo = m_lo.max(top - 4.0).floor();
    let m_hi = m_hi.ceil().max(m_lo + 1.0);
    let scales = Scales {
        f: (f_lo, f_hi),
        n_max,
        m: (m_lo, m_hi),
    };
    (scales, logs)
}

/// One position's diagram: axes, CMIF curves, rejected roots, pole
/// symbols, selected modes and the legend.
fn panel(s: &mut String, p: &Panel) {
    let (sc, logs) = scales(p);
    frame(s, p, &sc);
    cmif_curves(s, &p.data.frequencies_hz, &logs, &sc);
    rejected_roots(s, p.result, &sc);
    pole_symbols(s, p.result, &sc);
    selected_modes(s, p.result, &sc);
    legend(s, p.result.cmif.len());
}

/// One polyline per CMIF curve (`logs`, log10) over the lines `f`.
fn cmif_curves(s: &mut String, f: &[f64], logs: &[Vec<f64>], sc: &Scales) {
    for (k, curve) in logs.iter().enumerate() {
        let pts: Vec<String> = f
            .iter()
            .zip(curve)
            .map(|(&fv, &m)| format!("{:.1},{:.1}", sc.x(fv), sc.y_mag(m)))
            .collect();
        let _ = writeln!(
            s,
            r##"<polyline fill="none" stroke="{}" stroke-width="1" stroke-opacity="{}" points="{}"/>"##,
            CMIF_COLORS[k % CMIF_COLORS.len()],
            if k == 0 { 0.9 } else { 0.6 },
            pts.join(" ")
        );
    }
}

/// A grey tick at the top per root rejected by validation (a reduced
/// multiplicity is no rejection), its reason as tooltip.
fn rejected_roots(s: &mut String, r: &AutoEmaResult, sc: &Scales) {
    for rej in &r.best.rejected {
        if matches!(rej.reason, crate::ema::Reason::MultiplicityReduced { .. }) {
            continue;
        }
        let _ = writeln!(
            s,
            r##"<path d="M{0:.1} {1}v8" stroke="#777" stroke-width="1.5"><title>rejected {2:.3} Hz: {3}</title></path>"##,
            sc.x(rej.frequency_hz),
            TOP,
            rej.frequency_hz,
            esc(&serde_json::to_string(&rej.reason).unwrap_or_default())
        );
    }
}

/// The symbol of every pole inside the band at its order.
fn pole_symbols(s: &mut String, r: &AutoEmaResult, sc: &Scales) {
    let (f_lo, f_hi) = sc.f;
    for (j, flags) in r.best.flags.iter().enumerate() {
        let order = &r.orders[j];
        for (pole, fl) in order.poles.iter().zip(flags) {
            if pole.frequency_hz < f_lo || pole.frequency_hz > f_hi {
                continue;
            }
            if let Some(sym) = symbol(
                fl.class(),
                sc.x(pole.frequency_hz),
                sc.y_order(order.order as f64),
            ) {
                s.push_str(&sym);
                s.push('\n');
            }
        }
    }
}

/// Each selected mode as a red line with its representative pole ringed
/// (and ×m at a repeated root), its values as tooltip.
fn selected_modes(s: &mut String, r: &AutoEmaResult, sc: &Scales) {
    for root in &r.best.roots {
        let pole = root.pole(&r.orders);
        let order = r.orders[root.representative.0].order as f64;
        let (cx, cy) = (sc.x(pole.frequency_hz), sc.y_order(order));
        let mult = if root.multiplicity > 1 {
            format!(" ×{}", root.multiplicity)
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            r##"<g><title>{0:.3} Hz, ζ = {1:.4}{2}, stable over {3} orders</title><line x1="{cx:.1}" y1="{TOP}" x2="{cx:.1}" y2="{BOTTOM}" stroke="#d62728" stroke-opacity="0.7" stroke-dasharray="4,3"/><circle cx="{cx:.1}" cy="{cy:.1}" r="5" fill="none" stroke="#d62728" stroke-width="1.5"/></g>"##,
            pole.frequency_hz, pole.damping_ratio, mult, root.n_orders
        );
        if root.multiplicity > 1 {
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{}" fill="#d62728" font-size="11">×{}</text>"##,
                cx + 3.0,
                TOP + 12.0,
                root.multiplicity
            );
        }
    }
}

/// Axes, ticks, labels and title.
fn frame(s: &mut String, p: &Panel, sc: &Scales) {
    let (f_lo, f_hi) = sc.f;
    let (m_lo, m_hi) = sc.m;
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"#,
        (LEFT + RIGHT) / 2.0,
        esc(&p.title)
    );
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{}" height="{}" fill="none" stroke="#333"/>"##,
        RIGHT - LEFT,
        BOTTOM - TOP
    );
    // Axes as `g.axis` groups with `tick` labels and one `axis-title`
    // (the report's style guide, checked by `report::lint`).
    s.push_str(r#"<g class="axis" data-axis="x">"#);
    for t in ticks(f_lo, f_hi) {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.2}" y1="{BOTTOM}" x2="{0:.2}" y2="{1}" stroke="#333"/><text class="tick" x="{0:.2}" y="{2}" text-anchor="middle">{3}</text>"##,
            sc.x(t),
            BOTTOM + 5.0,
            BOTTOM + 18.0,
            t
        );
    }
    let _ = writeln!(
        s,
        r#"<text class="axis-title" x="{}" y="{}" text-anchor="middle">Frequency [Hz]</text></g><g class="axis" data-axis="y">"#,
        (LEFT + RIGHT) / 2.0,
        BOTTOM + 34.0
    );
    for t in ticks(0.0, sc.n_max) {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="#333"/><text class="tick" x="{2}" y="{3:.2}" text-anchor="end">{4}</text>"##,
            sc.y_order(t),
            LEFT - 5.0,
            LEFT - 8.0,
            sc.y_order(t) + 4.0,
            t
        );
    }
    let _ = writeln!(
        s,
        r#"<text class="axis-title" transform="translate(22,{}) rotate(-90)" text-anchor="middle">Model order [–]</text></g><g class="axis" data-axis="y2">"#,
        (TOP + BOTTOM) / 2.0
    );
    let mut d = m_lo;
    while d <= m_hi + 1e-9 {
        let _ = writeln!(
            s,
            r##"<line x1="{RIGHT}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="#1f77b4"/><text class="tick" x="{2}" y="{3:.2}" fill="#1f77b4">{4}</text>"##,
            sc.y_mag(d),
            RIGHT + 5.0,
            RIGHT + 8.0,
            sc.y_mag(d) + 4.0,
            super::format::power_of_ten(d as i32)
        );
        d += 1.0;
    }
    let _ = writeln!(
        s,
        r##"<text class="axis-title" transform="translate({},{}) rotate(90)" text-anchor="middle" fill="#1f77b4">CMIF singular values (log) [FRF units]</text></g>"##,
        W - 12.0,
        (TOP + BOTTOM) / 2.0
    );
}

/// The symbol legend under the axes.
fn legend(s: &mut String, n_curves: usize) {
    let ly = BOTTOM + 52.0;
    let mut lx = LEFT;
    let entries = [
        (PoleClass::Stable, "stable f, ζ, vector"),
        (PoleClass::Vector, "stable f, vector"),
        (PoleClass::Damping, "stable f, ζ"),
        (PoleClass::Frequency, "stable f"),
        (PoleClass::New, "new"),
    ];
    for (class, label) in entries {
        if let Some(sym) = symbol(class, lx, ly) {
            s.push_str(&sym);
        }
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}">{label}</text>"#,
            lx + 7.0,
            ly + 4.0
        );
        lx += 20.0 + 6.2 * label.len() as f64;
    }
    let _ = writeln!(
        s,
        r##"<circle cx="{0:.1}" cy="{1:.1}" r="5" fill="none" stroke="#d62728" stroke-width="1.5"/><text x="{2:.1}" y="{3:.1}">selected mode</text><path d="M{4:.1} {5:.1}v8" stroke="#777" stroke-width="1.5"/><text x="{6:.1}" y="{3:.1}">rejected root</text>"##,
        LEFT,
        ly + 20.0,
        LEFT + 9.0,
        ly + 24.0,
        LEFT + 110.0,
        ly + 16.0,
        LEFT + 117.0
    );
    for k in 0..n_curves {
        let x0 = LEFT + 220.0 + 90.0 * k as f64;
        let _ = writeln!(
            s,
            r##"<line x1="{x0:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{2}"/><text x="{3:.1}" y="{4:.1}">CMIF σ{5}</text>"##,
            ly + 20.0,
            x0 + 16.0,
            CMIF_COLORS[k % CMIF_COLORS.len()],
            x0 + 20.0,
            ly + 24.0,
            k + 1
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 100.0), vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        let t = ticks(5.0, 400.0);
        assert_eq!(t.first(), Some(&50.0));
        assert_eq!(t.last(), Some(&400.0));
    }
}
