//! Grouped bar charts (parameter errors, split validation) held to the
//! style guide: titled axes, legend right of the bars, title not clipped.

use super::axis;
use super::style::{text_width, LABEL_SIZE, TICK_SIZE, TITLE_SIZE};
use super::svg::{esc, header, PALETTE};
use std::fmt::Write;

/// Grouped vertical bars: one group per label (x axis titled `x_label`),
/// one bar per series.
pub fn bars(
    title: &str,
    (x_label, labels): (&str, &[String]),
    y_label: &str,
    series: &[(String, Vec<f64>)],
    caption: &str,
) -> String {
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
    let sy = |v: f64| t + ph - v / top * ph;
    let mut s = header(w, h, caption);
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    s.push_str(r#"<g class="axis" data-axis="y">"#);
    for (v, label) in ticks.at.iter().zip(&ticks.labels) {
        let y = sy(*v);
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
    s.push_str(r#"<g class="axis" data-axis="x">"#);
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
