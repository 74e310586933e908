//! Grouped bar charts (parameter errors, split validation) held to the
//! style guide: titled axes, legend right of the bars, title not clipped.

use super::axis;
use super::style::{text_width, LABEL_SIZE, TICK_SIZE, TITLE_SIZE};
use super::svg::{esc, header, PALETTE};
use std::fmt::Write;

/// Sizes of a bar chart, in px: the group width, the value axis (its top
/// and ticks), the frame's place (left `l`, top `t`) and size, and the
/// canvas.
struct Geometry {
    group: f64,
    top: f64,
    ticks: axis::Ticks,
    l: f64,
    t: f64,
    pw: f64,
    ph: f64,
    w: f64,
    h: f64,
}

impl Geometry {
    /// The y of value `v` on the canvas.
    fn sy(&self, v: f64) -> f64 {
        self.t + self.ph - v / self.top * self.ph
    }
}

/// The sizes that fit the values of `series`, the group `labels`, the
/// legend and `title`.
fn geometry(title: &str, labels: &[String], series: &[(String, Vec<f64>)]) -> Geometry {
    let group = 14.0 * series.len().max(1) as f64 + 10.0;
    let vmax = series
        .iter()
        .flat_map(|s| s.1.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let (_, top) = axis::nice_range(0.0, if vmax > 0.0 { vmax } else { 1.0 });
    let ticks = axis::linear(0.0, top);
    let tick_w = ticks
        .labels
        .iter()
        .map(|l| text_width(l, TICK_SIZE))
        .fold(0.0, f64::max);
    let label_h = labels
        .iter()
        .map(|l| text_width(l, 10.0))
        .fold(20.0, f64::max)
        * 0.87;
    let (l, t) = (tick_w + LABEL_SIZE + 22.0, 40.0);
    let (pw, ph) = ((group * labels.len() as f64).max(200.0), 260.0);
    let legend_w = series
        .iter()
        .map(|(n, _)| text_width(n, TICK_SIZE))
        .fold(0.0, f64::max)
        + 40.0;
    let w = (l + pw + legend_w + 10.0).max(text_width(title, TITLE_SIZE) + 24.0);
    let h = t + ph + label_h + LABEL_SIZE + 24.0;
    Geometry {
        group,
        top,
        ticks,
        l,
        t,
        pw,
        ph,
        w,
        h,
    }
}

/// Grouped vertical bars: one group per label (x axis titled `x_label`),
/// one bar per series.
pub fn bars(
    title: &str,
    (x_label, labels): (&str, &[String]),
    y_label: &str,
    series: &[(String, Vec<f64>)],
    caption: &str,
) -> String {
    let g = geometry(title, labels, series);
    let Geometry {
        l, t, pw, ph, w, h, ..
    } = g;
    let mut s = header(w, h, caption);
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    value_axis(&mut s, &g, y_label);
    groups(&mut s, &g, (x_label, labels), series);
    legend(&mut s, &g, series);
    let _ = write!(
        s,
        r##"<line x1="{l:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#444"/>"##,
        t + ph,
        l + pw,
        t + ph
    );
    s.push_str("</svg>\n");
    s
}

/// The y axis: grid lines with tick labels, and its rotated title.
fn value_axis(s: &mut String, g: &Geometry, y_label: &str) {
    let (l, t, pw, ph) = (g.l, g.t, g.pw, g.ph);
    s.push_str(r#"<g class="axis" data-axis="y">"#);
    for (v, label) in g.ticks.at.iter().zip(&g.ticks.labels) {
        let y = g.sy(*v);
        let _ = write!(
            s,
            r##"<line x1="{l:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#e3e3e3"/><text class="tick" x="{:.1}" y="{:.1}" font-size="{TICK_SIZE}" text-anchor="end">{}</text>"##,
            l + pw,
            l - 5.0,
            y + 4.0,
            esc(label)
        );
    }
    let cy = t + ph / 2.0;
    let _ = write!(
        s,
        r#"<text class="axis-title" x="{LABEL_SIZE}" y="{cy:.1}" font-size="{LABEL_SIZE}" text-anchor="middle" transform="rotate(-90 {LABEL_SIZE} {cy:.1})">{}</text></g>"#,
        esc(y_label)
    );
}

/// The x axis: per label a bar of each series with a positive value (its
/// tooltip the value) and the rotated label, then the axis title.
fn groups(
    s: &mut String,
    g: &Geometry,
    (x_label, labels): (&str, &[String]),
    series: &[(String, Vec<f64>)],
) {
    let (group, top, l, t, pw, ph, h) = (g.group, g.top, g.l, g.t, g.pw, g.ph, g.h);
    s.push_str(r#"<g class="axis" data-axis="x">"#);
    for (gi, label) in labels.iter().enumerate() {
        let x0 = l + group * gi as f64 + 5.0;
        for (k, (_, values)) in series.iter().enumerate() {
            let v = values.get(gi).copied().unwrap_or(f64::NAN);
            if v.is_finite() && v > 0.0 {
                let y = g.sy(v.min(top));
                let _ = write!(
                    s,
                    r#"<rect x="{:.1}" y="{y:.1}" width="12" height="{:.1}" fill="{}"><title>{}: {}</title></rect>"#,
                    x0 + 14.0 * k as f64,
                    t + ph - y,
                    PALETTE[k % PALETTE.len()],
                    esc(label),
                    super::format::sig(v, 4)
                );
            }
        }
        let xc = x0 + group / 2.0 - 5.0;
        let _ = write!(
            s,
            r#"<text class="category" x="{xc:.1}" y="{:.1}" font-size="10" text-anchor="end" transform="rotate(-60 {xc:.1} {:.1})">{}</text>"#,
            t + ph + 12.0,
            t + ph + 12.0,
            esc(label)
        );
    }
    let _ = write!(
        s,
        r#"<text class="axis-title" x="{:.1}" y="{:.1}" font-size="{LABEL_SIZE}" text-anchor="middle">{}</text></g>"#,
        l + pw / 2.0,
        h - 8.0,
        esc(x_label)
    );
}

/// A colour swatch and the name of each series, right of the frame.
fn legend(s: &mut String, g: &Geometry, series: &[(String, Vec<f64>)]) {
    let (l, t, pw) = (g.l, g.t, g.pw);
    for (k, (name, _)) in series.iter().enumerate() {
        let y = t + 10.0 + 16.0 * k as f64;
        let _ = write!(
            s,
            r#"<rect x="{:.1}" y="{:.1}" width="10" height="10" fill="{}"/><text x="{:.1}" y="{y:.1}" font-size="{TICK_SIZE}">{}</text>"#,
            l + pw + 15.0,
            y - 9.0,
            PALETTE[k % PALETTE.len()],
            l + pw + 30.0,
            esc(name)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bars_draw_one_rect_per_positive_value() {
        let labels = vec!["k1".to_string(), "k2".to_string()];
        let svg = bars(
            "errors",
            ("parameter", &labels),
            "|relative error| [%]",
            &[
                ("pso".into(), vec![3.0, 0.0]),
                ("ga".into(), vec![1.0, f64::NAN]),
            ],
            "",
        );
        assert_eq!(svg.matches("<title>").count(), 2);
        let problems = super::super::lint::check(&svg);
        assert!(problems.is_empty(), "{problems:?}");
    }
}
