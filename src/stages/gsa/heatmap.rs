//! The `heatmap` output of the `gsa` kind: total Sobol indices as an SVG
//! heatmap, one row per output and one column per parameter, written by hand
//! (no plotting dependency) so the bytes are deterministic.

use std::fmt::Write;

const CELL_W: f64 = 56.0;
const CELL_H: f64 = 26.0;
const CHAR_W: f64 = 7.0;

/// XML-escape a label.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Fill for an index in [0, 1]: white (0) to dark blue (1); values outside
/// [0, 1] (estimation noise) are clamped.
fn color(v: f64) -> String {
    let t = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mix = |lo: f64, hi: f64| (lo + t * (hi - lo)).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(255.0, 8.0),
        mix(255.0, 48.0),
        mix(255.0, 107.0)
    )
}

/// The SVG text of a heatmap of `values[output][parameter]`.
pub fn svg(title: &str, outputs: &[String], parameters: &[String], values: &[Vec<f64>]) -> String {
    let longest = |v: &[String]| v.iter().map(|s| s.chars().count()).max().unwrap_or(0) as f64;
    let left = 16.0 + CHAR_W * longest(outputs);
    // Column labels are rotated by −45°, so they need height ≈ their length / √2.
    let top = 48.0 + CHAR_W * longest(parameters) * std::f64::consts::FRAC_1_SQRT_2;
    let width = left + CELL_W * parameters.len() as f64 + 40.0 + CHAR_W * longest(parameters) * 0.7;
    let height = top + CELL_H * outputs.len() as f64 + 70.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="8" y="20" font-size="14" font-weight="bold">{}</text>"#,
        esc(title)
    );
    for (j, p) in parameters.iter().enumerate() {
        let x = left + CELL_W * (j as f64 + 0.5);
        let y = top - 6.0;
        let _ = writeln!(
            s,
            r#"<text x="{x:.1}" y="{y:.1}" transform="rotate(-45 {x:.1} {y:.1})">{}</text>"#,
            esc(p)
        );
    }
    for (i, (o, row)) in outputs.iter().zip(values).enumerate() {
        let y = top + CELL_H * i as f64;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
            left - 6.0,
            y + CELL_H * 0.65,
            esc(o)
        );
        for (j, v) in row.iter().enumerate() {
            let x = left + CELL_W * j as f64;
            let ink = if v.is_finite() && *v > 0.55 {
                "white"
            } else {
                "black"
            };
            let _ = writeln!(
                s,
                r#"<rect x="{x:.1}" y="{y:.1}" width="{CELL_W}" height="{CELL_H}" fill="{}" stroke="grey" stroke-width="0.5"><title>{} / {}: ST = {v}</title></rect>"#,
                color(*v),
                esc(o),
                esc(&parameters[j])
            );
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="{ink}">{v:.2}</text>"#,
                x + CELL_W / 2.0,
                y + CELL_H * 0.65
            );
        }
    }
    // Colour scale 0 … 1 below the map.
    let y = top + CELL_H * outputs.len() as f64 + 20.0;
    for k in 0..10 {
        let _ = writeln!(
            s,
            r#"<rect x="{:.1}" y="{y:.1}" width="16" height="12" fill="{}"/>"#,
            left + 16.0 * k as f64,
            color((k as f64 + 0.5) / 10.0)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">0</text>"#,
        left,
        y + 26.0
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">1</text>"#,
        left + 160.0,
        y + 26.0
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}">total index ST</text>"#,
        left + 172.0,
        y + 11.0
    );
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heatmap_has_one_cell_per_index_and_escaped_labels() {
        let outputs = vec!["f1 <pos=0>".to_string(), "f2".to_string()];
        let params = vec!["k&1".to_string(), "c1".to_string(), "m".to_string()];
        let v = vec![vec![0.9, 0.1, -0.01], vec![0.0, 1.2, 0.5]];
        let s = svg("Sobol ST", &outputs, &params, &v);
        assert!(s.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        assert!(s.trim_end().ends_with("</svg>"));
        assert_eq!(s.matches("<title>").count(), 6);
        assert!(s.contains("f1 &lt;pos=0&gt;") && s.contains("k&amp;1"));
        assert!(!s.contains("k&1"));
        assert!(s.contains(">0.90<") && s.contains(">-0.01<"));
        // Clamped colours: ≤ 0 white, ≥ 1 darkest.
        assert_eq!(color(-0.01), "#ffffff");
        assert_eq!(color(1.2), "#08306b");
        // Every opened element is closed (self-closing or paired).
        let opened = s.matches("<rect").count() + s.matches("<text").count();
        let closed =
            s.matches("/>").count() + s.matches("</rect>").count() + s.matches("</text>").count();
        assert_eq!(opened, closed);
    }
}
