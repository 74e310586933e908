//! Self-contained SVG charts for reports and stage outputs: line/point plots
//! with linear or logarithmic axes, and annotated heatmaps (MAC matrices,
//! Sobol indices). Text is plain SVG `<text>` in a generic sans-serif font,
//! so files need no embedded fonts or external assets and open in any
//! browser or be inlined into HTML.

use std::fmt::Write;

/// A data series of a [`Plot`].
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: String,
    /// `None`: a line; `Some(r)`: points of radius r.
    pub marker: Option<f64>,
}

impl Series {
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>, color: &str) -> Series {
        Series {
            name: name.into(),
            points,
            color: color.into(),
            marker: None,
        }
    }

    pub fn points(
        name: impl Into<String>,
        points: Vec<(f64, f64)>,
        color: &str,
        radius: f64,
    ) -> Series {
        Series {
            name: name.into(),
            points,
            color: color.into(),
            marker: Some(radius),
        }
    }
}

/// Colours for successive series (colour-blind-safe Okabe–Ito palette).
pub const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000",
];

/// An x–y chart.
#[derive(Clone, Debug)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub y_log: bool,
    pub series: Vec<Series>,
    /// Vertical reference lines at x with a label (e.g. identified modes).
    pub vlines: Vec<(f64, String)>,
    pub width: f64,
    pub height: f64,
}

impl Plot {
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Plot {
        Plot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            y_log: false,
            series: Vec::new(),
            vlines: Vec::new(),
            width: 720.0,
            height: 400.0,
        }
    }

    /// Render; non-finite points (and non-positive ones on a log axis) are skipped.
    pub fn to_svg(&self) -> String {
        let (l, r, t, b) = (70.0, 20.0, 36.0, 50.0);
        let (pw, ph) = (self.width - l - r, self.height - t - b);
        let ok = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && (!self.y_log || y > 0.0);
        let pts: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied().filter(ok))
            .collect();
        let ty = |y: f64| if self.y_log { y.log10() } else { y };
        let (mut x0, mut x1) = range(
            pts.iter()
                .map(|p| p.0)
                .chain(self.vlines.iter().map(|v| v.0)),
        );
        let (mut y0, mut y1) = range(pts.iter().map(|p| ty(p.1)));
        if self.y_log {
            (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
        } else {
            (y0, y1) = nice_range(y0, y1);
        }
        (x0, x1) = nice_range(x0, x1);
        let sx = |x: f64| l + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| t + ph - (ty(y) - y0) / (y1 - y0) * ph;
        let mut s = header(self.width, self.height);
        let _ = write!(
            s,
            r#"<text x="{}" y="22" font-size="15" text-anchor="middle" font-weight="bold">{}</text>"#,
            self.width / 2.0,
            esc(&self.title)
        );
        let _ = write!(
            s,
            r##"<rect x="{l}" y="{t}" width="{pw}" height="{ph}" fill="none" stroke="#444"/>"##
        );
        for v in ticks(x0, x1) {
            let x = sx(v);
            let _ = write!(
                s,
                r##"<line x1="{x:.1}" y1="{t}" x2="{x:.1}" y2="{}" stroke="#ddd"/><text x="{x:.1}" y="{}" font-size="11" text-anchor="middle">{}</text>"##,
                t + ph,
                t + ph + 15.0,
                fmt_tick(v)
            );
        }
        let yt: Vec<f64> = if self.y_log {
            (y0 as i64..=y1 as i64).map(|e| e as f64).collect()
        } else {
            ticks(y0, y1)
        };
        for v in yt {
            let y = t + ph - (v - y0) / (y1 - y0) * ph;
            let label = if self.y_log {
                format!("1e{}", v as i64)
            } else {
                fmt_tick(v)
            };
            let _ = write!(
                s,
                r##"<line x1="{l}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" font-size="11" text-anchor="end">{label}</text>"##,
                l + pw,
                l - 5.0,
                y + 4.0
            );
        }
        for (x, label) in &self.vlines {
            let px = sx(*x);
            let _ = write!(
                s,
                r##"<line x1="{px:.1}" y1="{t}" x2="{px:.1}" y2="{}" stroke="#888" stroke-dasharray="4 3"><title>{}</title></line>"##,
                t + ph,
                esc(label)
            );
        }
        for (k, series) in self.series.iter().enumerate() {
            let visible: Vec<(f64, f64)> = series.points.iter().copied().filter(ok).collect();
            match series.marker {
                None => {
                    let path: Vec<String> = visible
                        .iter()
                        .map(|&(x, y)| format!("{:.2},{:.2}", sx(x), sy(y)))
                        .collect();
                    let _ = write!(
                        s,
                        r#"<polyline fill="none" stroke="{}" stroke-width="1.4" points="{}"/>"#,
                        series.color,
                        path.join(" ")
                    );
                }
                Some(rad) => {
                    for &(x, y) in &visible {
                        let _ = write!(
                            s,
                            r#"<circle cx="{:.2}" cy="{:.2}" r="{rad}" fill="{}"/>"#,
                            sx(x),
                            sy(y),
                            series.color
                        );
                    }
                }
            }
            let ly = t + 14.0 + 16.0 * k as f64;
            let _ = write!(
                s,
                r#"<rect x="{}" y="{}" width="10" height="10" fill="{}"/><text x="{}" y="{ly}" font-size="11">{}</text>"#,
                l + pw - 150.0,
                ly - 9.0,
                series.color,
                l + pw - 135.0,
                esc(&series.name)
            );
        }
        let _ = write!(
            s,
            r#"<text x="{}" y="{}" font-size="12" text-anchor="middle">{}</text>"#,
            l + pw / 2.0,
            self.height - 10.0,
            esc(&self.x_label)
        );
        let _ = write!(
            s,
            r#"<text x="16" y="{}" font-size="12" text-anchor="middle" transform="rotate(-90 16 {})">{}</text>"#,
            t + ph / 2.0,
            t + ph / 2.0,
            esc(&self.y_label)
        );
        s.push_str("</svg>\n");
        s
    }
}

/// An annotated heatmap of `values[row][col]` on [vmin, vmax] (white → blue).
pub fn heatmap(
    title: &str,
    rows: &[String],
    cols: &[String],
    values: &[Vec<f64>],
    vmin: f64,
    vmax: f64,
) -> String {
    let cell = if rows.len().max(cols.len()) > 30 {
        14.0
    } else {
        28.0
    };
    let row_w = 8.0 * rows.iter().map(|r| r.chars().count()).max().unwrap_or(1) as f64 + 10.0;
    let col_h = 7.0 * cols.iter().map(|c| c.chars().count()).max().unwrap_or(1) as f64 + 10.0;
    let (l, t) = (row_w.max(40.0), 36.0 + col_h.max(20.0));
    let (w, h) = (
        l + cell * cols.len() as f64 + 70.0,
        t + cell * rows.len() as f64 + 20.0,
    );
    let mut s = header(w, h);
    let _ = write!(
        s,
        r#"<text x="{}" y="20" font-size="14" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    for (j, c) in cols.iter().enumerate() {
        let x = l + cell * (j as f64 + 0.5);
        let _ = write!(
            s,
            r#"<text x="{x:.1}" y="{}" font-size="10" transform="rotate(-60 {x:.1} {})">{}</text>"#,
            t - 4.0,
            t - 4.0,
            esc(c)
        );
    }
    for (i, row) in values.iter().enumerate() {
        let y = t + cell * i as f64;
        let _ = write!(
            s,
            r#"<text x="{}" y="{:.1}" font-size="10" text-anchor="end">{}</text>"#,
            l - 4.0,
            y + cell / 2.0 + 3.0,
            esc(rows.get(i).map_or("", String::as_str))
        );
        for (j, &v) in row.iter().enumerate() {
            let x = l + cell * j as f64;
            let u = if v.is_finite() {
                ((v - vmin) / (vmax - vmin)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let _ = write!(
                s,
                r##"<rect x="{x:.1}" y="{y:.1}" width="{cell}" height="{cell}" fill="{}" stroke="#fff"><title>{}: {}</title></rect>"##,
                blue(u),
                esc(&format!(
                    "{} / {}",
                    rows.get(i).map_or("", String::as_str),
                    cols.get(j).map_or("", String::as_str)
                )),
                fmt_tick(v)
            );
            if cell >= 28.0 {
                let color = if u > 0.6 { "#fff" } else { "#222" };
                let _ = write!(
                    s,
                    r#"<text x="{:.1}" y="{:.1}" font-size="9" text-anchor="middle" fill="{color}">{}</text>"#,
                    x + cell / 2.0,
                    y + cell / 2.0 + 3.0,
                    short(v)
                );
            }
        }
    }
    let cx = l + cell * cols.len() as f64 + 15.0;
    for k in 0..10 {
        let u = 1.0 - k as f64 / 9.0;
        let _ = write!(
            s,
            r#"<rect x="{cx}" y="{:.1}" width="14" height="10" fill="{}"/>"#,
            t + 10.0 * k as f64,
            blue(u)
        );
    }
    let _ = write!(
        s,
        r#"<text x="{}" y="{}" font-size="10">{}</text><text x="{}" y="{}" font-size="10">{}</text>"#,
        cx + 18.0,
        t + 9.0,
        fmt_tick(vmax),
        cx + 18.0,
        t + 99.0,
        fmt_tick(vmin)
    );
    s.push_str("</svg>\n");
    s
}

/// Grouped vertical bars: one group per label, one bar per series.
pub fn bars(
    title: &str,
    y_label: &str,
    labels: &[String],
    series: &[(String, Vec<f64>)],
) -> String {
    let group = 14.0 * series.len().max(1) as f64 + 10.0;
    let (l, t, b) = (70.0, 36.0, 110.0);
    let (pw, ph) = ((group * labels.len() as f64).max(200.0), 260.0);
    let (w, h) = (l + pw + 170.0, t + ph + b);
    let vmax = series
        .iter()
        .flat_map(|s| s.1.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let (_, top) = nice_range(0.0, if vmax > 0.0 { vmax } else { 1.0 });
    let sy = |v: f64| t + ph - v / top * ph;
    let mut s = header(w, h);
    let _ = write!(
        s,
        r#"<text x="{}" y="22" font-size="14" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    for v in ticks(0.0, top) {
        let y = sy(v);
        let _ = write!(
            s,
            r##"<line x1="{l}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" font-size="11" text-anchor="end">{}</text>"##,
            l + pw,
            l - 5.0,
            y + 4.0,
            fmt_tick(v)
        );
    }
    for (g, label) in labels.iter().enumerate() {
        let x0 = l + group * g as f64 + 5.0;
        for (k, (_, values)) in series.iter().enumerate() {
            let v = values.get(g).copied().unwrap_or(f64::NAN);
            if v.is_finite() && v > 0.0 {
                let y = sy(v.min(top));
                let _ = write!(
                    s,
                    r#"<rect x="{:.1}" y="{y:.1}" width="12" height="{:.1}" fill="{}"><title>{}: {}</title></rect>"#,
                    x0 + 14.0 * k as f64,
                    t + ph - y,
                    PALETTE[k % PALETTE.len()],
                    esc(label),
                    fmt_tick(v)
                );
            }
        }
        let xc = x0 + group / 2.0 - 5.0;
        let _ = write!(
            s,
            r#"<text x="{xc:.1}" y="{}" font-size="10" text-anchor="end" transform="rotate(-60 {xc:.1} {})">{}</text>"#,
            t + ph + 12.0,
            t + ph + 12.0,
            esc(label)
        );
    }
    for (k, (name, _)) in series.iter().enumerate() {
        let y = t + 10.0 + 16.0 * k as f64;
        let _ = write!(
            s,
            r#"<rect x="{}" y="{}" width="10" height="10" fill="{}"/><text x="{}" y="{}" font-size="11">{}</text>"#,
            l + pw + 15.0,
            y - 9.0,
            PALETTE[k % PALETTE.len()],
            l + pw + 30.0,
            y,
            esc(name)
        );
    }
    let _ = write!(
        s,
        r##"<line x1="{l}" y1="{}" x2="{}" y2="{}" stroke="#444"/>"##,
        t + ph,
        l + pw,
        t + ph
    );
    let _ = write!(
        s,
        r#"<text x="16" y="{}" font-size="12" text-anchor="middle" transform="rotate(-90 16 {})">{}</text>"#,
        t + ph / 2.0,
        t + ph / 2.0,
        esc(y_label)
    );
    s.push_str("</svg>\n");
    s
}

fn header(w: f64, h: f64) -> String {
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="Helvetica, Arial, sans-serif"><rect width="100%" height="100%" fill="white"/>"#
    )
}

fn blue(u: f64) -> String {
    let c = |a: f64, b: f64| (a + (b - a) * u).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        c(247.0, 8.0),
        c(251.0, 48.0),
        c(255.0, 107.0)
    )
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-12 * lo.abs().max(1.0) {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    }
}

fn step(lo: f64, hi: f64) -> f64 {
    let raw = (hi - lo) / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    mag * if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    }
}

fn nice_range(lo: f64, hi: f64) -> (f64, f64) {
    let s = step(lo, hi);
    ((lo / s).floor() * s, (hi / s).ceil() * s)
}

fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let s = step(lo, hi);
    let first = (lo / s).ceil() as i64;
    let last = (hi / s).floor() as i64;
    (first..=last).map(|k| k as f64 * s).collect()
}

fn fmt_tick(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e5 || v.abs() < 1e-3 {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn short(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "–".into()
    }
}

/// Escape text for SVG/HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn well_formed(svg: &str) {
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        // Every opened element is closed or self-closing.
        let opens = svg.matches("<text").count();
        assert_eq!(opens, svg.matches("</text>").count());
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn plot_maps_data_into_the_frame_and_skips_bad_points() {
        let mut p = Plot::new("FRF <overlay>", "frequency [Hz]", "|H| [m/N]");
        p.y_log = true;
        p.series.push(Series::line(
            "measured",
            vec![
                (0.0, 1e-6),
                (100.0, 1e-4),
                (200.0, f64::NAN),
                (300.0, 0.0),
                (400.0, 1e-7),
            ],
            PALETTE[0],
        ));
        p.vlines.push((125.7, "mode 1".into()));
        let svg = p.to_svg();
        well_formed(&svg);
        assert!(svg.contains("FRF &lt;overlay&gt;"));
        assert!(svg.contains("1e-7") && svg.contains("1e-4"), "decade ticks");
        assert_eq!(svg.matches("<polyline").count(), 1);
        // Three finite, positive points only.
        let pts = svg
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        assert_eq!(pts.split(' ').count(), 3);
    }

    #[test]
    fn heatmap_has_a_cell_per_value() {
        let rows = vec!["a".to_string(), "b".to_string()];
        let cols = vec!["x".to_string(), "y".to_string(), "z".to_string()];
        let svg = heatmap(
            "MAC",
            &rows,
            &cols,
            &[vec![1.0, 0.0, 0.5], vec![0.1, 0.9, f64::NAN]],
            0.0,
            1.0,
        );
        well_formed(&svg);
        assert_eq!(svg.matches("<title>").count(), 6);
        assert!(svg.contains("#08306b"), "the maximum is dark blue");
    }

    #[test]
    fn bars_draw_one_rect_per_positive_value() {
        let labels = vec!["k1".to_string(), "k2".to_string()];
        let svg = bars(
            "errors",
            "%",
            &labels,
            &[
                ("pso".into(), vec![3.0, 0.0]),
                ("ga".into(), vec![1.0, f64::NAN]),
            ],
        );
        well_formed(&svg);
        assert_eq!(svg.matches("<title>").count(), 2);
    }

    #[test]
    fn ticks_are_round_numbers() {
        assert_eq!(
            ticks(0.0, 400.0),
            vec![0.0, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0]
        );
        assert_eq!(nice_range(0.13, 0.97), (0.1, 1.0));
    }
}
