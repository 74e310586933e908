//! Numbers as text, to significant digits: the one rule (style guide rule
//! 7) every human-readable number follows, in reports, warnings and the
//! comments of written model files. A leaf module, so the numerical core
//! can use it without reaching the report ([`crate::report::format`] builds
//! its p-values and axis ticks on it).

/// `v` to `digits` significant digits: plain between 10⁻³ and 10⁵
/// (`0.005685`, `46.51`), else scientific (`2.406e6`, `3.953e-5`); `–` for
/// a non-finite value.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let d = digits.max(1);
    let rounded: f64 = format!("{v:.*e}", d - 1).parse().unwrap_or(v);
    if (1e-3..1e5).contains(&rounded.abs()) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}
