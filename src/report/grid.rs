//! Small multiples: one panel per channel (or any series group) in a grid
//! on a common x range, each panel titled, every y axis titled with its
//! unit, the x axis labelled on the bottom panel of each column, and one
//! legend (the first panel's series) right of the grid — so every channel
//! of a study is shown at a readable size instead of the first few.

use super::style::{text_width, LABEL_SIZE, TICK_SIZE, TITLE_SIZE};
use super::svg::{clip_id, esc, header, legend_box, panel, Frame, Plot, Shared};
use std::fmt::Write;

/// The panels in a grid of `columns` (at least 1); each panel's `title`
/// stands above its frame.
pub fn small_multiples(title: &str, caption: &str, panels: &[Plot], columns: usize) -> String {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let Shared {
        y_axes,
        x: (x0, x1),
        left: l,
        legend,
        legend_width: legend_w,
    } = Shared::of(panels);
    let pw = panels.iter().map(|p| p.width).fold(120.0, f64::max);
    let ph = panels.iter().map(|p| p.height).fold(80.0, f64::max);
    let cell_w = l + pw + 14.0;
    let head = TICK_SIZE + 8.0;
    let bottom = 2.0 * TICK_SIZE + LABEL_SIZE + 12.0;
    let cell_h = head + ph + bottom;
    let top = 36.0;
    let w = (columns as f64 * cell_w + 10.0 + legend_w).max(text_width(title, TITLE_SIZE) + 24.0);
    let h = top + rows as f64 * cell_h + 4.0;
    let mut s = header(w, h, caption);
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
        w / 2.0,
        esc(title)
    );
    for (k, (p, yax)) in panels.iter().zip(&y_axes).enumerate() {
        let (r, c) = (k / columns, k % columns);
        let ox = c as f64 * cell_w;
        let t = top + r as f64 * cell_h + head;
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" font-size="{TICK_SIZE}" font-weight="bold" text-anchor="middle">{}</text>"#,
            ox + l + pw / 2.0,
            t - 5.0,
            esc(&p.title)
        );
        let frame = Frame {
            l: ox + l,
            t,
            pw,
            ph,
            x: (x0, x1),
            y: (yax.0, yax.1),
            y_title_x: ox + LABEL_SIZE,
            clip: clip_id(title, caption, k),
        };
        // The x axis is labelled on the lowest panel of each column.
        panel(&mut s, p, &frame, &yax.2, k + columns >= panels.len());
    }
    legend_box(&mut s, &legend, columns as f64 * cell_w + 4.0, top + head);
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::svg::{Series, PALETTE};

    #[test]
    fn every_panel_is_drawn_titled_and_clean() {
        let panels: Vec<Plot> = (0..7)
            .map(|k| {
                let mut p = Plot::new(&format!("channel {k}"), "frequency [Hz]", "|H| [m/N]");
                p.y_log = true;
                p.width = 200.0;
                p.height = 110.0;
                p.series.push(Series::reference(
                    "reference",
                    (1..50)
                        .map(|i| (f64::from(i), 1e-6 * f64::from(i)))
                        .collect(),
                ));
                p.series.push(Series::line(
                    "candidate",
                    (1..50)
                        .map(|i| (f64::from(i), 2e-6 * f64::from(i)))
                        .collect(),
                    PALETTE[0],
                ));
                p
            })
            .collect();
        let svg = small_multiples("All channels", "caption", &panels, 3);
        for k in 0..7 {
            assert!(svg.contains(&format!(">channel {k}</text>")), "panel {k}");
        }
        // 7 y axes, and x axes on the lowest panel of each of the 3 columns.
        assert_eq!(svg.matches(r#"data-axis="y""#).count(), 7);
        assert_eq!(svg.matches(r#"data-axis="x""#).count(), 3);
        assert_eq!(svg.matches("<clipPath").count(), 7);
        let problems = crate::report::lint::check(&svg);
        assert!(problems.is_empty(), "{problems:?}");
    }
}
