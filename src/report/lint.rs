//! Structural checks of a figure against the style guide
//! ([`super::style`]), for tests and for the report stage's own warnings:
//!
//! - every axis (`<g class="axis">`) has exactly one non-empty title
//!   (`class="axis-title"`), and no tick label stands outside an axis;
//! - at most [`MAX_TICKS`] numeric tick labels (`class="tick"`) per axis;
//! - no text leaves the view box: each `<text>`'s box, estimated from its
//!   anchor, font size and [`text_width`], rotated as its `transform` says
//!   (`rotate(a cx cy)` or `translate(x,y) rotate(a)`), lies inside it.
//!
//! At the width a page shows a figure ([`check_rendered`]; the report's
//! column is [`PAGE_WIDTH`] px and a wider SVG is scaled down to it):
//!
//! - no text renders smaller than [`MIN_FONT_PX`];
//! - no two labels overlap (unrotated text boxes, estimated as above,
//!   sharing more than a quarter of the smaller one's area).
//!
//! The parser reads the flat SVG modalflow writes (no CSS, no nested
//! axis groups); it is a check, not a general SVG reader.

use super::style::{text_width, MAX_TICKS};

/// The width in px of the report's column (`max-width` of its body): an
/// SVG wider than this is scaled down to it.
pub const PAGE_WIDTH: f64 = 1100.0;
/// The smallest font a reader can read on a page, in rendered px.
pub const MIN_FONT_PX: f64 = 8.0;

/// The rendered-size problems of `svg` shown `width` px wide at most:
/// fonts below [`MIN_FONT_PX`] and overlapping labels, one line each.
pub fn check_rendered(svg: &str, width: f64) -> Vec<String> {
    let Some(view) = view_box(svg) else {
        return vec!["no viewBox on the <svg> element".into()];
    };
    let scale = (width / view[2]).min(1.0);
    let default_size = root_attr(svg, "font-size")
        .and_then(|v| v.parse().ok())
        .unwrap_or(12.0);
    let texts = texts(svg);
    let mut problems = Vec::new();
    let mut smallest: Option<(f64, String)> = None;
    for t in &texts {
        let size = size_of(t, default_size) * scale;
        if size < MIN_FONT_PX && smallest.as_ref().is_none_or(|(s, _)| size < *s) {
            smallest = Some((size, t.content.clone()));
        }
    }
    if let Some((size, text)) = smallest {
        problems.push(format!(
            "text {text:?} renders at {size:.1} px at {width:.0} px page width (at least {MIN_FONT_PX} px; the figure is {:.0} px wide)",
            view[2]
        ));
    }
    let offsets = text_offsets(svg);
    let boxes: Vec<(&Text, [f64; 4])> = texts
        .iter()
        .zip(offsets.iter().chain(std::iter::repeat(&(0.0, 0.0))))
        .filter_map(|(t, &(dx, dy))| {
            let b = text_box(t, default_size)?;
            Some((t, [b[0] + dx, b[1] + dy, b[2] + dx, b[3] + dy]))
        })
        .collect();
    let mut overlaps = 0;
    for (i, (a, ba)) in boxes.iter().enumerate() {
        for (b, bb) in &boxes[i + 1..] {
            let w = ba[2].min(bb[2]) - ba[0].max(bb[0]);
            let h = ba[3].min(bb[3]) - ba[1].max(bb[1]);
            let area = |r: &[f64; 4]| (r[2] - r[0]) * (r[3] - r[1]);
            if w > 0.0 && h > 0.0 && w * h > 0.25 * area(ba).min(area(bb)) {
                overlaps += 1;
                if overlaps <= 3 {
                    problems.push(format!(
                        "labels {:?} and {:?} overlap",
                        a.content, b.content
                    ));
                }
            }
        }
    }
    if overlaps > 3 {
        problems.push(format!("{} more overlapping label pairs", overlaps - 3));
    }
    problems
}

/// The offset of each `<text>`, in order, from the `translate(x,y)` of
/// the `<g>` groups around it (panels of a combined figure).
fn text_offsets(svg: &str) -> Vec<(f64, f64)> {
    let mut stack: Vec<(f64, f64)> = Vec::new();
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        rest = &rest[i..];
        if rest.starts_with("<g") && rest[2..].starts_with([' ', '>']) {
            let end = rest.find('>').unwrap_or(rest.len());
            let t = attr(&rest[..end], "transform")
                .and_then(|t| transform_args(&t, "translate"))
                .unwrap_or_default();
            let (x, y) = (
                t.first().copied().unwrap_or(0.0),
                t.get(1).copied().unwrap_or(0.0),
            );
            let (px, py) = stack.last().copied().unwrap_or((0.0, 0.0));
            stack.push((px + x, py + y));
        } else if rest.starts_with("</g>") {
            stack.pop();
        } else if rest.starts_with("<text") {
            out.push(stack.last().copied().unwrap_or((0.0, 0.0)));
        }
        rest = &rest[1..];
    }
    out
}

fn size_of(t: &Text, default_size: f64) -> f64 {
    attr(&t.attrs, "font-size")
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(default_size)
}

/// The box (x0, y0, x1, y1) of an unrotated, visible text; `None` for a
/// rotated or empty one.
fn text_box(t: &Text, default_size: f64) -> Option<[f64; 4]> {
    if t.content.trim().is_empty()
        || attr(&t.attrs, "fill").as_deref() == Some("none")
        || attr(&t.attrs, "transform").is_some()
    {
        return None;
    }
    let num = |k: &str| attr(&t.attrs, k).and_then(|v| v.parse::<f64>().ok());
    let size = size_of(t, default_size);
    let (x, y) = (num("x")?, num("y")?);
    let w = text_width(&t.content, size);
    let x0 = match attr(&t.attrs, "text-anchor").as_deref() {
        Some("middle") => x - w / 2.0,
        Some("end") => x - w,
        _ => x,
    };
    Some([x0, y - 0.8 * size, x0 + w, y + 0.25 * size])
}

/// The problems found in `svg`, one line each; empty when it passes.
pub fn check(svg: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let Some(view) = view_box(svg) else {
        return vec!["no viewBox on the <svg> element".into()];
    };
    let default_size = root_attr(svg, "font-size")
        .and_then(|v| v.parse().ok())
        .unwrap_or(12.0);
    for t in texts(svg) {
        if let Some(why) = outside(&t, view, default_size) {
            problems.push(why);
        }
    }
    let mut rest = svg;
    let mut in_axes = 0;
    while let Some(i) = rest.find("<g class=\"axis\"") {
        let group = &rest[i..];
        let end = group.find("</g>").unwrap_or(group.len());
        let body = &group[..end];
        let axis = attr(body, "data-axis").unwrap_or_else(|| "?".into());
        let titles: Vec<Text> = texts(body)
            .into_iter()
            .filter(|t| t.class == "axis-title")
            .collect();
        match titles.as_slice() {
            [t] if !t.content.trim().is_empty() => {}
            [] => problems.push(format!("axis {axis} has no title")),
            [_] => problems.push(format!("axis {axis} has an empty title")),
            _ => problems.push(format!("axis {axis} has {} titles", titles.len())),
        }
        let ticks = texts(body).iter().filter(|t| t.class == "tick").count();
        in_axes += ticks;
        if ticks > MAX_TICKS {
            problems.push(format!(
                "axis {axis} has {ticks} tick labels (at most {MAX_TICKS})"
            ));
        }
        rest = &group[end..];
    }
    let all_ticks = texts(svg).iter().filter(|t| t.class == "tick").count();
    if all_ticks > in_axes {
        problems.push(format!(
            "{} tick label(s) outside an axis group",
            all_ticks - in_axes
        ));
    }
    problems
}

/// One `<text>` element.
struct Text {
    attrs: String,
    content: String,
    class: String,
}

fn texts(svg: &str) -> Vec<Text> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find("<text") {
        let after = &rest[i + 5..];
        let Some(gt) = after.find('>') else { break };
        let attrs = after[..gt].to_string();
        let body = &after[gt + 1..];
        let end = body.find("</text>").unwrap_or(body.len());
        // Nested <tspan>s count with their text.
        let mut content = String::new();
        let mut depth = 0;
        for c in body[..end].chars() {
            match c {
                '<' => depth += 1,
                '>' => depth -= 1,
                _ if depth == 0 => content.push(c),
                _ => {}
            }
        }
        let content = content
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&amp;", "&");
        let class = attr(&attrs, "class").unwrap_or_default();
        out.push(Text {
            attrs,
            content,
            class,
        });
        rest = &body[end..];
    }
    out
}

/// The value of attribute `name` in an element's attribute text.
fn attr(attrs: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let i = attrs.find(&key)? + key.len();
    let j = attrs[i..].find('"')?;
    Some(attrs[i..i + j].to_string())
}

fn root_attr(svg: &str, name: &str) -> Option<String> {
    let start = svg.find("<svg")?;
    let end = start + svg[start..].find('>')?;
    attr(&svg[start..end], name)
}

fn view_box(svg: &str) -> Option<[f64; 4]> {
    let v: Vec<f64> = root_attr(svg, "viewBox")?
        .split([' ', ','])
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.parse().ok())
        .collect();
    (v.len() == 4).then(|| [v[0], v[1], v[2], v[3]])
}

/// Numbers inside `name( … )` of a transform.
fn transform_args(transform: &str, name: &str) -> Option<Vec<f64>> {
    let i = transform.find(&format!("{name}("))? + name.len() + 1;
    let j = transform[i..].find(')')?;
    Some(
        transform[i..i + j]
            .split([' ', ','])
            .filter(|s| !s.is_empty())
            .filter_map(|s| s.parse().ok())
            .collect(),
    )
}

/// Why `t` leaves the view box, if it does.
fn outside(t: &Text, [vx, vy, vw, vh]: [f64; 4], default_size: f64) -> Option<String> {
    let num = |k: &str| attr(&t.attrs, k).and_then(|v| v.parse::<f64>().ok());
    let size = num("font-size").unwrap_or(default_size);
    if t.content.trim().is_empty() || attr(&t.attrs, "fill").as_deref() == Some("none") {
        return None;
    }
    let (mut x, mut y) = (num("x").unwrap_or(0.0), num("y").unwrap_or(0.0));
    let w = text_width(&t.content, size);
    let (x0, x1) = match attr(&t.attrs, "text-anchor").as_deref() {
        Some("middle") => (-w / 2.0, w / 2.0),
        Some("end") => (-w, 0.0),
        _ => (0.0, w),
    };
    let (y0, y1) = (-0.8 * size, 0.25 * size);
    let transform = attr(&t.attrs, "transform").unwrap_or_default();
    let mut angle = 0.0_f64;
    let mut pivot = (x, y);
    if let Some(tr) = transform_args(&transform, "translate") {
        x += tr.first().copied().unwrap_or(0.0);
        y += tr.get(1).copied().unwrap_or(0.0);
        pivot = (x, y);
    }
    if let Some(r) = transform_args(&transform, "rotate") {
        angle = r.first().copied().unwrap_or(0.0).to_radians();
        if r.len() == 3 {
            pivot = (r[1], r[2]);
        }
    }
    let (sin, cos) = angle.sin_cos();
    let tol = 1.0;
    for (dx, dy) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
        // The corner in text coordinates, rotated about the pivot.
        let (px, py) = (x + dx - pivot.0, y + dy - pivot.1);
        let (cx, cy) = (pivot.0 + px * cos - py * sin, pivot.1 + px * sin + py * cos);
        if cx < vx - tol || cx > vx + vw + tol || cy < vy - tol || cy > vy + vh + tol {
            return Some(format!(
                "text {:?} reaches ({cx:.0}, {cy:.0}), outside the view box {vw:.0} × {vh:.0}",
                t.content
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_clipped_text_missing_titles_and_crowded_ticks() {
        let ok = r#"<svg viewBox="0 0 200 100"><g class="axis" data-axis="x"><text class="tick" x="50" y="80" font-size="10" text-anchor="middle">1</text><text class="axis-title" x="100" y="95" font-size="10" text-anchor="middle">f [Hz]</text></g></svg>"#;
        assert!(check(ok).is_empty(), "{:?}", check(ok));
        let clipped = r#"<svg viewBox="0 0 100 100"><text x="50" y="20" font-size="15" text-anchor="middle">A title far wider than the canvas</text></svg>"#;
        assert_eq!(check(clipped).len(), 1);
        let rotated = r#"<svg viewBox="0 0 100 100"><text x="10" y="50" font-size="12" text-anchor="middle" transform="rotate(-90 10 50)">y [m/N]</text></svg>"#;
        assert!(check(rotated).is_empty(), "{:?}", check(rotated));
        let untitled = r#"<svg viewBox="0 0 200 100"><g class="axis" data-axis="y"><text class="tick" x="50" y="50">1</text></g><text class="tick" x="60" y="60">2</text></svg>"#;
        let p = check(untitled);
        assert!(p.iter().any(|m| m.contains("no title")), "{p:?}");
        assert!(p.iter().any(|m| m.contains("outside an axis")), "{p:?}");
        let ticks: String = (0..20)
            .map(|k| {
                format!(
                    r#"<text class="tick" x="{}" y="50" font-size="8">{k}</text>"#,
                    10 * k
                )
            })
            .collect();
        let crowded = format!(
            r#"<svg viewBox="0 0 300 100"><g class="axis" data-axis="x">{ticks}<text class="axis-title" x="100" y="90">x</text></g></svg>"#
        );
        assert!(check(&crowded).iter().any(|m| m.contains("20 tick labels")));
    }

    #[test]
    fn finds_small_fonts_and_overlaps_at_the_rendered_width() {
        let ok = r#"<svg viewBox="0 0 400 100"><text x="10" y="20" font-size="11">left</text><text x="200" y="20" font-size="11">right</text></svg>"#;
        assert!(check_rendered(ok, PAGE_WIDTH).is_empty());
        // 4,000 px wide: scaled to 1,100, 11 px text renders at 3 px.
        let wide = ok.replace("0 0 400 100", "0 0 4000 100");
        let p = check_rendered(&wide, PAGE_WIDTH);
        assert!(p.iter().any(|m| m.contains("renders at 3.0 px")), "{p:?}");
        let clash = r#"<svg viewBox="0 0 400 100"><text x="10" y="20" font-size="11">mode 1 · 45 Hz</text><text x="14" y="22" font-size="11">mode 2 · 46 Hz</text></svg>"#;
        let p = check_rendered(clash, PAGE_WIDTH);
        assert!(p.iter().any(|m| m.contains("overlap")), "{p:?}");
        // Panels moved apart by their groups do not overlap.
        let panels = r#"<svg viewBox="0 0 400 300"><g transform="translate(0,0)"><text x="10" y="20" font-size="11">panel</text></g><g transform="translate(0,150)"><text x="10" y="20" font-size="11">panel</text></g></svg>"#;
        assert!(check_rendered(panels, PAGE_WIDTH).is_empty());
    }
}
