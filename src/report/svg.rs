//! Self-contained SVG line/point charts held to the style guide
//! ([`super::style`]): titled axes with units, round or decade ticks, the
//! legend outside the frame, references dashed and beneath, one or more
//! panels on a shared x axis (FRF magnitude over phase). Text is plain SVG
//! `<text>`, so files need no assets, open in any browser and inline into
//! HTML; the caption travels in `<desc>`.
//!
//! Axes are `<g class="axis">` groups holding their tick labels
//! (`class="tick"`) and exactly one title (`class="axis-title"`), which is
//! what [`super::lint`] checks.

use super::axis::{self, Ticks};
use super::style::{
    text_width, CANDIDATE_WIDTH, FONT, LABEL_SIZE, REFERENCE_COLOR, REFERENCE_DASH,
    REFERENCE_WIDTH, TICK_SIZE, TITLE_SIZE,
};
use std::fmt::Write;

pub use super::bars::bars;
pub use super::grid::small_multiples;
pub use super::heatmap::heatmap;

/// A data series of a [`Plot`].
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: String,
    /// `None`: a line; `Some(r)`: points of radius r.
    pub marker: Option<f64>,
    /// Stroke dash pattern (`"7 4"`), `None` for solid.
    pub dash: Option<String>,
    pub width: f64,
}

impl Series {
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>, color: &str) -> Series {
        Series {
            name: name.into(),
            points,
            color: color.into(),
            marker: None,
            dash: None,
            width: CANDIDATE_WIDTH,
        }
    }

    /// A reference curve: near-black, dashed and wide (style rule 4); add
    /// it before the candidates so it is drawn beneath them.
    pub fn reference(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            dash: Some(REFERENCE_DASH.into()),
            width: REFERENCE_WIDTH,
            ..Series::line(name, points, REFERENCE_COLOR)
        }
    }

    pub fn points(
        name: impl Into<String>,
        points: Vec<(f64, f64)>,
        color: &str,
        radius: f64,
    ) -> Series {
        Series {
            marker: Some(radius),
            ..Series::line(name, points, color)
        }
    }
}

/// Colours for successive series (colour-blind-safe Okabe–Ito palette,
/// black left out: it is the reference's).
pub const PALETTE: [&str; 7] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#999933",
];

/// An x–y chart (one panel).
#[derive(Clone, Debug)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub y_log: bool,
    /// Fixed y range and ticks (e.g. phase: −180 to 180 every 90).
    pub y_fixed: Option<(f64, f64, f64)>,
    pub series: Vec<Series>,
    /// Vertical reference lines at x with a label (e.g. identified modes).
    pub vlines: Vec<(f64, String)>,
    /// Size of the plot frame (data area) in px.
    pub width: f64,
    pub height: f64,
    /// What the figure shows, stored in `<desc>`.
    pub caption: String,
}

impl Plot {
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Plot {
        Plot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            y_log: false,
            y_fixed: None,
            series: Vec::new(),
            vlines: Vec::new(),
            width: 620.0,
            height: 320.0,
            caption: String::new(),
        }
    }

    /// Render as one figure.
    pub fn to_svg(&self) -> String {
        stacked(&self.title, &self.caption, std::slice::from_ref(self))
    }

    pub(super) fn visible(&self, p: &(f64, f64)) -> bool {
        p.0.is_finite() && p.1.is_finite() && (!self.y_log || p.1 > 0.0)
    }

    /// The y axis: (lo, hi) in axis units (log10 on a log axis) and ticks.
    pub(super) fn y_axis(&self) -> (f64, f64, Ticks) {
        if let Some((lo, hi, step)) = self.y_fixed {
            let n = ((hi - lo) / step).round() as i64;
            let at: Vec<f64> = (0..=n).map(|k| lo + k as f64 * step).collect();
            let labels = at.iter().map(|&v| super::format::tick(v, step)).collect();
            return (lo, hi, Ticks { at, labels });
        }
        let ty = |y: f64| if self.y_log { y.log10() } else { y };
        let (lo, hi) = axis::range(
            self.series
                .iter()
                .flat_map(|s| s.points.iter().filter(|p| self.visible(p)).map(|p| ty(p.1))),
        );
        if self.y_log {
            let (lo, hi) = (lo.floor(), hi.ceil().max(lo.floor() + 1.0));
            (lo, hi, axis::log(lo as i32, hi as i32))
        } else {
            let (lo, hi) = axis::nice_range(lo, hi);
            (lo, hi, axis::linear(lo, hi))
        }
    }

    pub(super) fn x_range(&self) -> (f64, f64) {
        let (lo, hi) = axis::range(
            self.series
                .iter()
                .flat_map(|s| s.points.iter().filter(|p| self.visible(p)).map(|p| p.0))
                .chain(self.vlines.iter().map(|v| v.0)),
        );
        axis::nice_range(lo, hi)
    }
}

/// Left margin a panel's y tick labels and title need.
pub(super) fn left_margin(ticks: &Ticks) -> f64 {
    let widest = ticks
        .labels
        .iter()
        .map(|l| text_width(l, TICK_SIZE))
        .fold(0.0, f64::max);
    widest + 8.0 + LABEL_SIZE + 14.0
}

/// What panels drawn together share: their y axes, the union of their x
/// ranges ((0, 1) when none is finite), the left margin the widest y tick
/// labels need, and one legend (the first panel's series) with its width.
pub(super) struct Shared<'a> {
    pub y_axes: Vec<(f64, f64, Ticks)>,
    pub x: (f64, f64),
    pub left: f64,
    pub legend: Vec<&'a Series>,
    pub legend_width: f64,
}

impl<'a> Shared<'a> {
    pub fn of(panels: &'a [Plot]) -> Shared<'a> {
        let y_axes: Vec<(f64, f64, Ticks)> = panels.iter().map(Plot::y_axis).collect();
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in panels {
            let (a, b) = p.x_range();
            (x0, x1) = (x0.min(a), x1.max(b));
        }
        if !x0.is_finite() {
            (x0, x1) = (0.0, 1.0);
        }
        let left = y_axes
            .iter()
            .map(|a| left_margin(&a.2))
            .fold(40.0, f64::max);
        let legend: Vec<&Series> = panels
            .first()
            .map_or(Vec::new(), |p| p.series.iter().collect());
        let legend_width = legend
            .iter()
            .map(|s| text_width(&s.name, TICK_SIZE))
            .fold(0.0, f64::max)
            + if legend.is_empty() { 0.0 } else { 48.0 };
        Shared {
            y_axes,
            x: (x0, x1),
            left,
            legend,
            legend_width,
        }
    }
}

/// Panels stacked on one x axis (the x range is the union of theirs; only
/// the last shows the x title), one legend (the first panel's series) right
/// of the frames, `title` on top and `caption` in `<desc>`.
pub fn stacked(title: &str, caption: &str, panels: &[Plot]) -> String {
    let Shared {
        y_axes,
        x: (x0, x1),
        left: l,
        legend,
        legend_width: legend_w,
    } = Shared::of(panels);
    let pw = panels.iter().map(|p| p.width).fold(200.0, f64::max);
    let top = if title.is_empty() { 12.0 } else { 36.0 };
    let gap = 14.0;
    let bottom = 2.0 * TICK_SIZE + LABEL_SIZE + 16.0;
    let heights: f64 = panels.iter().map(|p| p.height).sum();
    let mut w = l + pw + 16.0 + legend_w;
    w = w.max(text_width(title, TITLE_SIZE) + 24.0);
    let h = top + heights + gap * panels.len().saturating_sub(1) as f64 + bottom;
    let mut s = header(w, h, caption);
    if !title.is_empty() {
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
            w / 2.0,
            esc(title)
        );
    }
    let mut y = top;
    for (k, (p, yax)) in panels.iter().zip(&y_axes).enumerate() {
        let last = k + 1 == panels.len();
        let frame = Frame {
            l,
            t: y,
            pw,
            ph: p.height,
            x: (x0, x1),
            y: (yax.0, yax.1),
            y_title_x: LABEL_SIZE,
            clip: clip_id(title, caption, k),
        };
        panel(&mut s, p, &frame, &yax.2, last);
        y += p.height + gap;
    }
    legend_box(&mut s, &legend, l + pw + 16.0, top);
    s.push_str("</svg>\n");
    s
}

/// Where a panel's data go.
pub(super) struct Frame {
    pub l: f64,
    pub t: f64,
    pub pw: f64,
    pub ph: f64,
    pub x: (f64, f64),
    pub y: (f64, f64),
    /// Where the y-axis title stands (its x), left of the tick labels.
    pub y_title_x: f64,
    /// The clip path's id, unique in a page that inlines many figures.
    pub clip: String,
}

impl Frame {
    fn sx(&self, x: f64) -> f64 {
        self.l + (x - self.x.0) / (self.x.1 - self.x.0) * self.pw
    }
    fn sy(&self, y: f64) -> f64 {
        self.t + self.ph - (y - self.y.0) / (self.y.1 - self.y.0) * self.ph
    }
}

/// A clip-path id from the figure's title and caption and the panel's
/// number: figures inlined in one HTML page must not share ids.
pub(super) fn clip_id(title: &str, caption: &str, k: usize) -> String {
    let h = blake3::hash(format!("{title}\u{1f}{caption}").as_bytes());
    format!("c{}-{k}", &h.to_hex()[..10])
}

/// One panel of a figure in `f`: frame, axes (the x axis labelled and
/// titled only `with_x_title`), then the vertical lines and the series,
/// clipped to the frame.
pub(super) fn panel(s: &mut String, p: &Plot, f: &Frame, y_ticks: &Ticks, with_x_title: bool) {
    let (l, t, pw, ph) = (f.l, f.t, f.pw, f.ph);
    let _ = write!(
        s,
        r##"<rect x="{l:.1}" y="{t:.1}" width="{pw:.1}" height="{ph:.1}" fill="none" stroke="#444"/>"##
    );
    panel_x_axis(s, p, f, with_x_title);
    panel_y_axis(s, p, f, y_ticks);
    let _ = write!(
        s,
        r#"<clipPath id="{0}"><rect x="{l:.1}" y="{t:.1}" width="{pw:.1}" height="{ph:.1}"/></clipPath><g class="data" clip-path="url(#{0})">"#,
        f.clip
    );
    for (x, label) in &p.vlines {
        let px = f.sx(*x);
        let _ = write!(
            s,
            r##"<line x1="{px:.1}" y1="{t:.1}" x2="{px:.1}" y2="{:.1}" stroke="#999" stroke-dasharray="2 3"><title>{}</title></line>"##,
            t + ph,
            esc(label)
        );
    }
    for series in &p.series {
        match series.marker {
            None => polylines(s, p, f, series),
            Some(rad) => markers(s, p, f, series, rad),
        }
    }
    s.push_str("</g>");
}

/// The x axis of a panel: grid lines and, `with_x_title` (the last panel
/// of a stack), tick labels and title.
fn panel_x_axis(s: &mut String, p: &Plot, f: &Frame, with_x_title: bool) {
    let (l, t, pw, ph) = (f.l, f.t, f.pw, f.ph);
    // x axis: grid lines and, on the last panel, labels and title.
    let xt = axis::linear(f.x.0, f.x.1);
    if with_x_title {
        s.push_str(r#"<g class="axis" data-axis="x">"#);
    }
    for (v, label) in xt.at.iter().zip(&xt.labels) {
        let x = f.sx(*v);
        let _ = write!(
            s,
            r##"<line x1="{x:.1}" y1="{t:.1}" x2="{x:.1}" y2="{:.1}" stroke="#e3e3e3"/>"##,
            t + ph
        );
        if with_x_title {
            let _ = write!(
                s,
                r#"<text class="tick" x="{x:.1}" y="{:.1}" font-size="{TICK_SIZE}" text-anchor="middle">{}</text>"#,
                t + ph + TICK_SIZE + 4.0,
                esc(label)
            );
        }
    }
    // A shared x axis is labelled and titled on the last panel only.
    if with_x_title {
        let _ = write!(
            s,
            r#"<text class="axis-title" x="{:.1}" y="{:.1}" font-size="{LABEL_SIZE}" text-anchor="middle">{}</text></g>"#,
            l + pw / 2.0,
            t + ph + 2.0 * TICK_SIZE + LABEL_SIZE + 6.0,
            esc(&p.x_label)
        );
    }
}

/// The y axis of a panel: grid lines with the tick labels `y_ticks`, and
/// its rotated title.
fn panel_y_axis(s: &mut String, p: &Plot, f: &Frame, y_ticks: &Ticks) {
    let (l, t, pw, ph) = (f.l, f.t, f.pw, f.ph);
    s.push_str(r#"<g class="axis" data-axis="y">"#);
    for (v, label) in y_ticks.at.iter().zip(&y_ticks.labels) {
        let y = f.sy(*v);
        let _ = write!(
            s,
            r##"<line x1="{l:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#e3e3e3"/><text class="tick" x="{:.1}" y="{:.1}" font-size="{TICK_SIZE}" text-anchor="end">{}</text>"##,
            l + pw,
            l - 5.0,
            y + 4.0,
            esc(label)
        );
    }
    let (cy, tx) = (t + ph / 2.0, f.y_title_x);
    let _ = write!(
        s,
        r#"<text class="axis-title" x="{tx:.1}" y="{cy:.1}" font-size="{LABEL_SIZE}" text-anchor="middle" transform="rotate(-90 {tx:.1} {cy:.1})">{}</text>"#,
        esc(&p.y_label)
    );
    s.push_str("</g>");
}

/// The y of `y` on the panel's axis (log10 on a log axis).
fn axis_y(p: &Plot, y: f64) -> f64 {
    if p.y_log {
        y.log10()
    } else {
        y
    }
}

/// A line series as polylines, one per run of drawable points.
fn polylines(s: &mut String, p: &Plot, f: &Frame, series: &Series) {
    // A point that cannot be drawn (NaN, ≤ 0 on a log axis)
    // breaks the line: phase wraps, gaps in the data.
    let dash = series
        .dash
        .as_ref()
        .map_or(String::new(), |d| format!(r#" stroke-dasharray="{d}""#));
    for run in series
        .points
        .split(|q| !p.visible(q))
        .filter(|r| !r.is_empty())
    {
        let pts: Vec<String> = run
            .iter()
            .map(|&(x, y)| format!("{:.2},{:.2}", f.sx(x), f.sy(axis_y(p, y))))
            .collect();
        let _ = write!(
            s,
            r#"<polyline fill="none" stroke="{}" stroke-width="{}"{dash} stroke-linejoin="round" points="{}"><title>{}</title></polyline>"#,
            series.color,
            series.width,
            pts.join(" "),
            esc(&series.name)
        );
    }
}

/// A point series as circles of radius `rad` at its drawable points.
fn markers(s: &mut String, p: &Plot, f: &Frame, series: &Series, rad: f64) {
    let visible = series.points.iter().copied().filter(|q| p.visible(q));
    for (x, y) in visible {
        let _ = write!(
            s,
            r#"<circle cx="{:.2}" cy="{:.2}" r="{rad}" fill="{}"/>"#,
            f.sx(x),
            f.sy(axis_y(p, y)),
            series.color
        );
    }
}

pub(super) fn legend_box(s: &mut String, series: &[&Series], x: f64, top: f64) {
    for (k, series) in series.iter().enumerate() {
        let y = top + 10.0 + 18.0 * k as f64;
        let sample = match series.marker {
            Some(r) => format!(
                r#"<circle cx="{:.1}" cy="{:.1}" r="{r}" fill="{}"/>"#,
                x + 14.0,
                y - 4.0,
                series.color
            ),
            None => format!(
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="{}"{}/>"#,
                y - 4.0,
                x + 28.0,
                y - 4.0,
                series.color,
                series.width,
                series
                    .dash
                    .as_ref()
                    .map_or(String::new(), |d| format!(r#" stroke-dasharray="{d}""#))
            ),
        };
        s.push_str(&sample);
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{y:.1}" font-size="{TICK_SIZE}">{}</text>"#,
            x + 34.0,
            esc(&series.name)
        );
    }
}

/// The `<svg>` opening with a white background and the caption.
pub fn header(w: f64, h: f64, caption: &str) -> String {
    let mut s = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{h:.0}" viewBox="0 0 {w:.0} {h:.0}" font-family="{FONT}"><rect width="100%" height="100%" fill="white"/>"#
    );
    if !caption.is_empty() {
        let _ = write!(s, "<desc>{}</desc>", esc(caption));
    }
    s
}

/// The caption stored in an SVG's `<desc>`, if any.
pub fn caption_of(svg: &str) -> Option<String> {
    let start = svg.find("<desc>")? + "<desc>".len();
    let end = start + svg[start..].find("</desc>")?;
    let text = &svg[start..end];
    Some(
        text.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&amp;", "&"),
    )
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

    #[test]
    fn plot_maps_data_into_the_frame_and_skips_bad_points() {
        let mut p = Plot::new("FRF <overlay>", "frequency [Hz]", "|H| [m/N]");
        p.y_log = true;
        p.caption = "a caption".into();
        p.series.push(Series::reference(
            "measured",
            vec![
                (0.0, 1e-6),
                (100.0, 1e-4),
                (200.0, f64::NAN),
                (300.0, 0.0),
                (400.0, 1e-7),
            ],
        ));
        p.vlines.push((125.7, "mode 1".into()));
        let svg = p.to_svg();
        assert!(svg.contains("FRF &lt;overlay&gt;"));
        assert!(svg.contains("10⁻⁷") && svg.contains("10⁻⁴"), "decade ticks");
        assert!(svg.contains("stroke-dasharray=\"7 4\""), "reference dashed");
        assert_eq!(caption_of(&svg).as_deref(), Some("a caption"));
        // Five points, two undrawable: runs of 2 and 1 points.
        assert_eq!(svg.matches("<polyline").count(), 2);
        let pts = svg
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        assert_eq!(pts.split(' ').count(), 2);
        assert!(
            super::super::lint::check(&svg).is_empty(),
            "{:?}",
            super::super::lint::check(&svg)
        );
    }

    #[test]
    fn long_titles_and_legends_widen_the_canvas() {
        let title = "A very long title that would be cut off on both sides of a narrow chart";
        let mut p = Plot::new(title, "x [–]", "y [–]");
        p.width = 200.0;
        p.series.push(Series::line(
            "a series with a long legend entry",
            vec![(0.0, 1.0), (1.0, 2.0)],
            PALETTE[0],
        ));
        let svg = p.to_svg();
        assert!(
            super::super::lint::check(&svg).is_empty(),
            "{:?}",
            super::super::lint::check(&svg)
        );
    }
}
