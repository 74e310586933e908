//! Reports: self-contained HTML and Markdown pages with SVG charts.

pub mod document;
pub mod svg;
