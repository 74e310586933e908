//! The figure style guide of modalflow: what every figure a stage or report
//! draws is held to, so that it can go into a paper as it is. The helpers of
//! [`super::svg`], [`super::heatmap`] and [`super::shapes`] implement it, and
//! [`super::lint`] checks the structural rules on every report a test
//! renders.
//!
//! 1. **Axes.** Every axis has a title with its unit in brackets:
//!    `frequency [Hz]`, `|H| [m/N]` (m/s/N for mobility, m/s²/N for
//!    accelerance, by the FRF's quantity), `phase [°]`, `1 − mean MAC [–]`.
//!    Categorical axes (modes, parameters, outputs) are titled as well
//!    (`reference mode`, `parameter`).
//! 2. **Ticks.** At most [`MAX_TICKS`] labelled ticks per axis: round steps
//!    (1, 2, 5 × 10ᵏ) on linear axes, decades written 10ⁿ on log axes, every
//!    k-th decade when the range spans more than 8 (a convergence curve
//!    from 10¹ to 10⁻³² labels 10⁰, 10⁻⁵, …).
//! 3. **Nothing clipped.** The canvas grows with the title, the tick labels
//!    and the legend; the legend sits outside the plot frame, right of it, so
//!    it never covers data. No text leaves the view box.
//! 4. **The reference is visible.** A reference curve is drawn first, in
//!    near-black, wider and dashed ([`REFERENCE_COLOR`], [`REFERENCE_DASH`]),
//!    so a candidate lying on it leaves it visible; candidates are thinner,
//!    solid, in the Okabe–Ito palette (colour-blind safe).
//! 5. **FRF overlays** show magnitude (log) and phase (−180° to 180°) in two
//!    panels on one frequency axis.
//! 6. **MAC matrices** are labelled with mode number and frequency on both
//!    axes (`3 · 56.9 Hz`), with axis titles naming what is compared and a
//!    colour bar.
//! 7. **Numbers** are written to significant digits
//!    ([`super::format::sig`]): 4 in tables, scientific notation below 10⁻³
//!    and from 10⁵; p-values in scientific notation with 2 digits, and
//!    `< 1e-16` below the resolution of a double.
//! 8. **Captions** say what is shown (quantity, position, compared with what),
//!    never a file name; each SVG carries its caption in `<desc>` so the
//!    report can use it.
//! 9. **Files.** Every report figure is also saved standalone as SVG and as
//!    PNG (2× scale, fonts embedded: DejaVu Sans from the `dejavu` crate,
//!    rendered by resvg, so the picture is the same on every machine).
//! 10. **Dense plots** (FRF overlays, stabilization diagrams) can be zoomed
//!     in the HTML page: wheel to zoom, drag to pan, double click to reset
//!     (a small inline script, no network).

/// Font stack of every text element (DejaVu Sans first: the PNG renderer
/// embeds it, and browsers without it fall back to a similar sans).
pub const FONT: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
/// Font sizes in px.
pub const TITLE_SIZE: f64 = 15.0;
pub const LABEL_SIZE: f64 = 12.0;
pub const TICK_SIZE: f64 = 11.0;
/// Most labelled ticks on one numeric axis.
pub const MAX_TICKS: usize = 12;
/// Reference curves: near-black, dashed, wider than candidates.
pub const REFERENCE_COLOR: &str = "#222222";
pub const REFERENCE_DASH: &str = "7 4";
pub const REFERENCE_WIDTH: f64 = 2.2;
pub const CANDIDATE_WIDTH: f64 = 1.3;

/// Width in px of `s` at font size `size`, an upper estimate for DejaVu
/// Sans (average advance ≈ 0.55 em; 0.62 em leaves room for wide glyphs).
pub fn text_width(s: &str, size: f64) -> f64 {
    s.chars().count() as f64 * 0.62 * size
}
