//! Annotated heatmaps (MAC matrices, Sobol indices, ANOVA shares) held to
//! the style guide: both axes titled, category labels that fit the cells,
//! a colour bar with its range, the title never clipped.

use super::style::{text_width, LABEL_SIZE, TITLE_SIZE};
use super::svg::{esc, header};
use std::fmt::Write;

/// One titled categorical axis: its title and a label per row or column.
pub type Categories<'a> = (&'a str, &'a [String]);

/// Sizes of a heatmap, in px: the cell and its font, the grid's place
/// (left `l`, top `t`) and size, and the canvas.
struct Geometry {
    cell: f64,
    font: f64,
    l: f64,
    t: f64,
    grid_w: f64,
    grid_h: f64,
    w: f64,
    h: f64,
}

/// The sizes that fit the labels of `rows` and `cols`, the row axis title
/// and `title`.
fn geometry(title: &str, row_title: &str, rows: &[String], cols: &[String]) -> Geometry {
    // The columns set the cell size; many rows only make the map taller
    // (99 outputs × 25 parameters stay readable at 14 px).
    let n = cols.len().max(rows.len() / 2);
    let cell: f64 = if n > 60 {
        9.0
    } else if n > 30 {
        14.0
    } else {
        30.0
    };
    let font = (cell * 0.75).clamp(7.0, 10.0);
    let row_w = rows
        .iter()
        .map(|r| text_width(r, font))
        .fold(20.0, f64::max)
        + 8.0;
    // Column labels are rotated by −60°: they rise by sin 60° of their length.
    let col_h = cols
        .iter()
        .map(|c| text_width(c, font))
        .fold(20.0, f64::max)
        * 0.87
        + 8.0;
    let l = LABEL_SIZE + 12.0 + row_w;
    let t = 36.0 + col_h + LABEL_SIZE + 8.0;
    let grid_w = cell * cols.len() as f64;
    let grid_h = cell * rows.len() as f64;
    // The last column label leans right by cos 60° of its length.
    let lean = cols.last().map_or(0.0, |c| text_width(c, font) * 0.5);
    let w = (l + grid_w + lean.max(90.0) + 10.0).max(text_width(title, TITLE_SIZE) + 24.0);
    // The rotated row title must fit beside the grid, however few rows.
    let row_title_half = text_width(row_title, LABEL_SIZE) / 2.0;
    let h = (t + grid_h.max(110.0) + 16.0).max(t + grid_h / 2.0 + row_title_half + 8.0);
    Geometry {
        cell,
        font,
        l,
        t,
        grid_w,
        grid_h,
        w,
        h,
    }
}

/// An annotated heatmap of `values[row][col]` on [vmin, vmax] (white →
/// blue), rows and columns given as (axis title, labels); `caption` goes
/// into `<desc>`.
pub fn heatmap(
    title: &str,
    rows: Categories<'_>,
    cols: Categories<'_>,
    values: &[Vec<f64>],
    (vmin, vmax): (f64, f64),
    caption: &str,
) -> String {
    let (row_title, rows) = rows;
    let (col_title, cols) = cols;
    let g = geometry(title, row_title, rows, cols);
    let mut s = header(g.w, g.h, caption);
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="22" font-size="{TITLE_SIZE}" text-anchor="middle" font-weight="bold">{}</text>"#,
        g.w / 2.0,
        esc(title)
    );
    column_axis(&mut s, &g, (col_title, cols));
    row_axis(&mut s, &g, (row_title, rows));
    cells(&mut s, &g, (rows, cols), values, (vmin, vmax));
    colour_bar(&mut s, g.l + g.grid_w + 12.0, g.t, (vmin, vmax));
    s.push_str("</svg>\n");
    s
}

/// The x axis: a rotated label per column above the grid, and its title.
fn column_axis(s: &mut String, g: &Geometry, (col_title, cols): Categories<'_>) {
    let Geometry {
        cell,
        font,
        l,
        t,
        grid_w,
        ..
    } = *g;
    s.push_str(r#"<g class="axis" data-axis="x">"#);
    for (j, c) in cols.iter().enumerate() {
        let x = l + cell * (j as f64 + 0.5);
        let _ = write!(
            s,
            r#"<text class="category" x="{x:.1}" y="{:.1}" font-size="{font}" transform="rotate(-60 {x:.1} {:.1})">{}</text>"#,
            t - 4.0,
            t - 4.0,
            esc(c)
        );
    }
    let _ = write!(
        s,
        r#"<text class="axis-title" x="{:.1}" y="{:.1}" font-size="{LABEL_SIZE}" text-anchor="middle" font-weight="bold">{}</text></g>"#,
        l + grid_w / 2.0,
        36.0 + LABEL_SIZE,
        esc(col_title)
    );
}

/// The y axis: a label per row left of the grid, and its rotated title.
fn row_axis(s: &mut String, g: &Geometry, (row_title, rows): Categories<'_>) {
    let Geometry {
        cell,
        font,
        l,
        t,
        grid_h,
        ..
    } = *g;
    s.push_str(r#"<g class="axis" data-axis="y">"#);
    for (i, r) in rows.iter().enumerate() {
        let y = t + cell * (i as f64 + 0.5) + font / 3.0;
        let _ = write!(
            s,
            r#"<text class="category" x="{:.1}" y="{y:.1}" font-size="{font}" text-anchor="end">{}</text>"#,
            l - 4.0,
            esc(r)
        );
    }
    let cy = t + grid_h / 2.0;
    let _ = write!(
        s,
        r#"<text class="axis-title" x="{LABEL_SIZE}" y="{cy:.1}" font-size="{LABEL_SIZE}" text-anchor="middle" font-weight="bold" transform="rotate(-90 {LABEL_SIZE} {cy:.1})">{}</text></g>"#,
        esc(row_title)
    );
}

/// A coloured cell per value with its row, column and value as tooltip,
/// and the value written in it when the cell is large enough.
fn cells(
    s: &mut String,
    g: &Geometry,
    (rows, cols): (&[String], &[String]),
    values: &[Vec<f64>],
    (vmin, vmax): (f64, f64),
) {
    let Geometry { cell, l, t, .. } = *g;
    for (i, row) in values.iter().enumerate() {
        let y = t + cell * i as f64;
        for (j, &v) in row.iter().enumerate() {
            let x = l + cell * j as f64;
            let u = if v.is_finite() {
                ((v - vmin) / (vmax - vmin)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let _ = write!(
                s,
                r##"<rect x="{x:.1}" y="{y:.1}" width="{cell}" height="{cell}" fill="{}" stroke="#fff"><title>{} / {}: {}</title></rect>"##,
                blue(u),
                esc(rows.get(i).map_or("", String::as_str)),
                esc(cols.get(j).map_or("", String::as_str)),
                super::format::sig(v, 3)
            );
            if cell >= 28.0 {
                let color = if u > 0.6 { "#fff" } else { "#222" };
                let _ = write!(
                    s,
                    r#"<text x="{:.1}" y="{:.1}" font-size="9" text-anchor="middle" fill="{color}">{}</text>"#,
                    x + cell / 2.0,
                    y + cell / 2.0 + 3.0,
                    if v.is_finite() {
                        format!("{v:.2}")
                    } else {
                        "–".into()
                    }
                );
            }
        }
    }
}

fn colour_bar(s: &mut String, cx: f64, t: f64, (vmin, vmax): (f64, f64)) {
    for k in 0..10 {
        let u = 1.0 - k as f64 / 9.0;
        let _ = write!(
            s,
            r#"<rect x="{cx:.1}" y="{:.1}" width="14" height="10" fill="{}"/>"#,
            t + 10.0 * k as f64,
            blue(u)
        );
    }
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="{:.1}" font-size="10">{}</text><text x="{:.1}" y="{:.1}" font-size="10">{}</text>"#,
        cx + 18.0,
        t + 9.0,
        super::format::sig(vmax, 3),
        cx + 18.0,
        t + 99.0,
        super::format::sig(vmin, 3)
    );
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heatmap_has_a_cell_per_value_and_titled_axes() {
        let rows = vec!["1 · 12.5 Hz".to_string(), "2 · 40.1 Hz".to_string()];
        let cols = vec!["x".to_string(), "y".to_string(), "z".to_string()];
        let svg = heatmap(
            "MAC of a rather long title that must not be clipped anywhere",
            ("reference mode", &rows),
            ("candidate mode", &cols),
            &[vec![1.0, 0.0, 0.5], vec![0.1, 0.9, f64::NAN]],
            (0.0, 1.0),
            "caption",
        );
        assert_eq!(svg.matches("<title>").count(), 6);
        assert!(svg.contains("#08306b"), "the maximum is dark blue");
        let problems = super::super::lint::check(&svg);
        assert!(problems.is_empty(), "{problems:?}");
    }
}
