//! The stabilization diagram as a self-contained SVG, written as text: poles
//! over model order on top of the sum of the FRF magnitudes (log scale),
//! stable poles filled, unstable ones as small rings, selected modes as
//! vertical lines. One panel per position.

use super::{FrfData, PoleOrder, Selection};
use std::fmt::Write;

/// One position's panel content.
pub struct Panel<'a> {
    pub title: String,
    pub data: &'a FrfData,
    pub orders: &'a [PoleOrder],
    pub selection: &'a Selection,
}

const W: f64 = 900.0;
const PANEL_H: f64 = 430.0;
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

fn panel(s: &mut String, p: &Panel) {
    let f = &p.data.frequencies_hz;
    let (f_lo, f_hi) = (
        f.first().copied().unwrap_or(0.0),
        f.last().copied().unwrap_or(1.0),
    );
    let n_max = p.orders.last().map_or(1, |o| o.order).max(1) as f64;
    let x = |v: f64| LEFT + (v - f_lo) / (f_hi - f_lo).max(1e-12) * (RIGHT - LEFT);
    let y_order = |n: f64| BOTTOM - n / n_max * (BOTTOM - TOP);
    // Sum of magnitudes over channels, log10 scale on the right axis.
    let nf = p.data.n_lines();
    let n_ch = p.data.n_out() * p.data.n_ref();
    let sum: Vec<f64> = (0..nf)
        .map(|i| {
            (0..n_ch)
                .map(|c| p.data.h[c * nf + i].norm())
                .sum::<f64>()
                .max(1e-300)
                .log10()
        })
        .collect();
    let (m_lo, m_hi) = sum
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let (m_lo, m_hi) = (m_lo.floor(), m_hi.ceil().max(m_lo.floor() + 1.0));
    let y_mag = |v: f64| BOTTOM - (v - m_lo) / (m_hi - m_lo) * (BOTTOM - TOP);
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
    for t in ticks(f_lo, f_hi) {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.2}" y1="{BOTTOM}" x2="{0:.2}" y2="{1}" stroke="#333"/><text x="{0:.2}" y="{2}" text-anchor="middle">{3}</text>"##,
            x(t),
            BOTTOM + 5.0,
            BOTTOM + 18.0,
            t
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">Frequency [Hz]</text>"#,
        (LEFT + RIGHT) / 2.0,
        BOTTOM + 38.0
    );
    for t in ticks(0.0, n_max) {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="#333"/><text x="{2}" y="{3:.2}" text-anchor="end">{4}</text>"##,
            y_order(t),
            LEFT - 5.0,
            LEFT - 8.0,
            y_order(t) + 4.0,
            t
        );
    }
    let _ = writeln!(
        s,
        r#"<text transform="translate(22,{}) rotate(-90)" text-anchor="middle">Model order</text>"#,
        (TOP + BOTTOM) / 2.0
    );
    let mut d = m_lo;
    while d <= m_hi + 1e-9 {
        let _ = writeln!(
            s,
            r##"<line x1="{RIGHT}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="#1f77b4"/><text x="{2}" y="{3:.2}" fill="#1f77b4">1e{4}</text>"##,
            y_mag(d),
            RIGHT + 5.0,
            RIGHT + 8.0,
            y_mag(d) + 4.0,
            d
        );
        d += 1.0;
    }
    let _ = writeln!(
        s,
        r##"<text transform="translate({},{}) rotate(90)" text-anchor="middle" fill="#1f77b4">Sum of |H| (log)</text>"##,
        W - 12.0,
        (TOP + BOTTOM) / 2.0
    );
    let pts: Vec<String> = f
        .iter()
        .zip(&sum)
        .map(|(&fv, &m)| format!("{:.2},{:.2}", x(fv), y_mag(m)))
        .collect();
    let _ = writeln!(
        s,
        r##"<polyline fill="none" stroke="#1f77b4" stroke-width="1" points="{}"/>"##,
        pts.join(" ")
    );
    for c in &p.selection.clusters {
        let pole = &p.orders[c.representative.0].poles[c.representative.1];
        let _ = writeln!(
            s,
            r##"<line x1="{0:.2}" y1="{TOP}" x2="{0:.2}" y2="{BOTTOM}" stroke="#d62728" stroke-dasharray="4,3"><title>{1:.3} Hz, ζ = {2:.4}</title></line>"##,
            x(pole.frequency_hz),
            pole.frequency_hz,
            pole.damping_ratio
        );
    }
    for (j, flags) in p.selection.flags.iter().enumerate() {
        let order = &p.orders[j];
        for (pole, fl) in order.poles.iter().zip(flags) {
            if pole.frequency_hz < f_lo || pole.frequency_hz > f_hi {
                continue;
            }
            let (cx, cy) = (x(pole.frequency_hz), y_order(order.order as f64));
            if fl.stable() {
                let _ = writeln!(
                    s,
                    r##"<circle cx="{cx:.2}" cy="{cy:.2}" r="2.5" fill="#2ca02c"/>"##
                );
            } else {
                let _ = writeln!(
                    s,
                    r##"<circle cx="{cx:.2}" cy="{cy:.2}" r="1.8" fill="none" stroke="#999"/>"##
                );
            }
        }
    }
    let ly = BOTTOM + 52.0;
    let _ = writeln!(
        s,
        r##"<circle cx="{LEFT}" cy="{ly}" r="3" fill="#2ca02c"/><text x="{}" y="{}">stable pole</text><circle cx="{}" cy="{ly}" r="2" fill="none" stroke="#999"/><text x="{}" y="{}">other pole</text><line x1="{}" y1="{}" x2="{}" y2="{}" stroke="#d62728" stroke-dasharray="4,3"/><text x="{}" y="{}">selected mode</text>"##,
        LEFT + 8.0,
        ly + 4.0,
        LEFT + 110.0,
        LEFT + 118.0,
        ly + 4.0,
        LEFT + 220.0,
        ly - 6.0,
        LEFT + 220.0,
        ly + 6.0,
        LEFT + 228.0,
        ly + 4.0
    );
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
