//! Reports: self-contained HTML and Markdown pages with SVG figures held to
//! one style guide ([`style`]), figures also as PNG ([`raster`]), mode
//! shapes drawn on the structure ([`shapes`]), AutoEMA's stabilization
//! diagrams ([`stabilization`]), and the structural checks
//! of a figure ([`lint`]).

pub mod axis;
pub mod bars;
pub mod document;
pub mod format;
pub mod grid;
pub mod heatmap;
pub mod lint;
pub mod raster;
pub mod shapes;
pub mod stabilization;
pub mod style;
pub mod svg;
pub mod zoom;
