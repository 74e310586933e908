//! Axis ranges and ticks (style guide rule 2): round linear steps and
//! decade ticks on log axes, at most [`MAX_TICKS`] labels per axis.

use super::format::{power_of_ten, tick};
use super::style::MAX_TICKS;

/// Labelled ticks of an axis: positions in axis units (log10 on a log
/// axis) and their labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Ticks {
    pub at: Vec<f64>,
    pub labels: Vec<String>,
}

/// A round step (1, 2, 5 × 10ᵏ) giving about 6 intervals on [lo, hi].
pub fn step(lo: f64, hi: f64) -> f64 {
    let raw = ((hi - lo) / 6.0).max(f64::MIN_POSITIVE);
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    mag * if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    }
}

/// [lo, hi] widened to multiples of the step.
pub fn nice_range(lo: f64, hi: f64) -> (f64, f64) {
    let s = step(lo, hi);
    ((lo / s).floor() * s, (hi / s).ceil() * s)
}

/// Ticks at the multiples of the round step inside [lo, hi].
pub fn linear(lo: f64, hi: f64) -> Ticks {
    let s = step(lo, hi);
    let first = (lo / s - 1e-9).ceil() as i64;
    let last = (hi / s + 1e-9).floor() as i64;
    let at: Vec<f64> = (first..=last).map(|k| k as f64 * s).collect();
    let labels = at.iter().map(|&v| tick(v, s)).collect();
    Ticks { at, labels }
}

/// Decade ticks between the exponents `lo` and `hi` (log10 units, whole
/// numbers): every decade up to 8, else every k-th with k the smallest of
/// 2, 5, 10, 20, … that keeps at most [`MAX_TICKS`] / 1.5 labels.
pub fn log(lo: i32, hi: i32) -> Ticks {
    let span = (hi - lo).max(1);
    let mut k = 1;
    for candidate in [1, 2, 5, 10, 20, 50, 100] {
        k = candidate;
        if span / k <= 8 {
            break;
        }
    }
    let first = lo.div_euclid(k) * k + if lo.rem_euclid(k) == 0 { 0 } else { k };
    let at: Vec<f64> = (first..=hi).step_by(k as usize).map(|e| e as f64).collect();
    let labels = at.iter().map(|&e| power_of_ten(e as i32)).collect();
    debug_assert!(at.len() <= MAX_TICKS);
    Ticks { at, labels }
}

/// (min, max) of the finite values, widened when they coincide.
pub fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-12 * lo.abs().max(1.0) {
        (lo - 0.5, hi + 0.5)
    } else {
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_ticks_are_round_numbers() {
        let t = linear(0.0, 400.0);
        assert_eq!(
            t.at,
            vec![0.0, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0, 400.0]
        );
        assert_eq!(t.labels[3], "150");
        assert_eq!(nice_range(0.13, 0.97), (0.1, 1.0));
        assert!(linear(-180.0, 180.0).at.len() <= MAX_TICKS);
    }

    #[test]
    fn log_ticks_thin_out_over_many_decades() {
        let t = log(-7, -4);
        assert_eq!(t.at, vec![-7.0, -6.0, -5.0, -4.0]);
        assert_eq!(t.labels[0], "10⁻⁷");
        // A convergence curve from 1e1 to 1e-32: every 5th decade.
        let t = log(-32, 1);
        assert!(t.at.len() <= 8, "{:?}", t.at);
        assert_eq!(t.at.first(), Some(&-30.0));
        assert_eq!(t.labels.last().map(String::as_str), Some("10⁰"));
        for (lo, hi) in [(-300, 300), (0, 1), (-3, -3)] {
            assert!(log(lo, hi).at.len() <= MAX_TICKS);
        }
    }
}
