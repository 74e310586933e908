//! Figures as PNG for papers and slides (style guide rule 9): the SVG is
//! rendered by resvg (pure Rust) with DejaVu Sans embedded from the
//! `dejavu` crate, so text renders the same on every machine, with or
//! without system fonts.

use resvg::{tiny_skia, usvg};
use std::sync::{Arc, OnceLock};

/// Parse options with the embedded fonts, built once.
fn options() -> &'static usvg::Options<'static> {
    static OPTIONS: OnceLock<usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family("DejaVu Sans");
        usvg::Options {
            font_family: "DejaVu Sans".into(),
            fontdb: Arc::new(db),
            ..usvg::Options::default()
        }
    })
}

/// PNG bytes of `svg` at `scale` × its size (2 for print-ready figures).
pub fn png(svg: &str, scale: f32) -> Result<Vec<u8>, String> {
    let tree =
        usvg::Tree::from_str(svg, options()).map_err(|e| format!("SVG not readable: {e}"))?;
    let size = tree
        .size()
        .to_int_size()
        .scale_by(scale)
        .ok_or("figure too small to render")?;
    let mut pixmap =
        tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("figure too large to render")?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    pixmap
        .encode_png()
        .map_err(|e| format!("PNG encoding: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_text_with_the_embedded_font() {
        let blank = r#"<svg xmlns="http://www.w3.org/2000/svg" width="120" height="40" viewBox="0 0 120 40"><rect width="100%" height="100%" fill="white"/></svg>"#;
        let text = r#"<svg xmlns="http://www.w3.org/2000/svg" width="120" height="40" viewBox="0 0 120 40" font-family="DejaVu Sans, Helvetica, sans-serif"><rect width="100%" height="100%" fill="white"/><text x="10" y="25" font-size="16">|H| [m/N]</text></svg>"#;
        let a = png(blank, 2.0).unwrap();
        let b = png(text, 2.0).unwrap();
        assert_eq!(&b[1..4], b"PNG");
        // The text adds ink: the PNG of the same canvas grows.
        assert!(b.len() > a.len() + 200, "{} vs {}", b.len(), a.len());
        assert!(png("<svg", 1.0).is_err());
    }
}
