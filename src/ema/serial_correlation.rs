//! Serial correlation of a fit's residual along the frequency axis, and how
//! much it inflates the evidence a root seems to have.
//!
//! The significance test ([`super::significance`]) takes the residual of
//! the fit as independent from line to line: where no mode is, a root's
//! ΔRSS_c is σ_c²/2 · χ²₂. Measurement noise nearly is. Model error is not:
//! what a modal model of measured FRFs misses (leakage, a structure that is
//! not quite linear or time-invariant, a roving hammer's small
//! inconsistencies between points, a noise profile that is only right block
//! by block) is smooth over tens to hundreds of lines. The residual of the
//! tool holder's driving point (`benchmarks/real_sets`, autoema 21) has a
//! lag-1 autocorrelation of 0.99; the other measured sets −0.3 to 0.8;
//! three synthetic families (close pair, damping, wide band; seed 1, 2 %
//! noise) −0.02 to 0.04. A heavily damped root laid over such a
//! smooth misfit lowers RSS by far more than χ²₂ allows, and passes as a
//! mode: 639, 684, 2377, 3238 and 3457 Hz on the tool holder, with scores
//! 1.7–12.
//!
//! **Inflation.** For a stationary residual of variance σ² and
//! autocorrelation ρ(j) at a lag of j lines, the projection of the residual
//! on a root's column b has variance σ² Σ_j ρ(j) a(j), a(j) the column's
//! own autocorrelation. For p = 1/(iω − λ), λ = −ζω_r + iω_d, it is
//! ∫ p(ω) p*(ω + jΔω) dω / ∫ |p|² dω = 1/(1 − i j/B) with B = 2ζf/Δf the
//! half-power band in lines. Against such a residual the root's ΔRSS, and
//! so its significance score, is worth 1/I of its face value, with
//!
//! I = 1 + 2 Σ_{j ≥ 1} Re ρ(j) / (1 + (j/B)²)   (at least 1),
//!
//! the long-run (HAC) variance of Newey & West (1987) seen through the
//! root's column (the product of the imaginary parts, a phase drift of the
//! residual against the pole's, is left out). White noise gives I = 1; a
//! residual smooth over L ≫ B lines gives I ≈ πB. The consensus step of
//! the search ([`super::search`]) drops a mode kept for significance alone
//! whose score is below I, unless most of the next-best selections hold it.
//!
//! **Local.** The residual is taken around the root only, over
//! ± max(5B, 20) lines, pooled over the strongest channels: the misfit of a
//! strong mode elsewhere in the band neither hides a weak mode nor excuses
//! a spurious one. It is first averaged over blocks of d = ⌊B/8⌋ lines (at
//! least 1): a(j) changes on the scale of B, and the block means keep what
//! is smooth on that scale while white noise falls by d, so
//!
//! I = d · (γ_y(0) + 2 Σ_{k=1}^{K} a(kd) γ_y(k)) / γ_r(0),  K = ⌈4B/d⌉,
//!
//! with γ_y the (biased) autocovariance of the block means and γ_r(0) the
//! mean |r|² of the lines; white noise gives γ_y(0) = γ_r(0)/d and I = 1.
//!
//! **Only what is significant.** A window of N blocks estimates I with a
//! standard error of about 2 (Σ_k a(kd)²/N)^½ under white noise (0.54 for
//! any root wider than 8 lines: the window holds about ten independent
//! stretches of the root's width; 0.3 at B = 2, where the window's floor of
//! 41 lines is wider), divided by √(channels pooled). The
//! inflation used is 1 + max(0, Î − 1 − 2 se): a residual whose correlation
//! the window cannot tell from white noise counts as white, so synthetic
//! data with white noise and a sufficient model analyse as before.

use num_complex::Complex64;

/// Half-widths of a root's window, in half-power bands B.
pub const HALF_WIDTH_BANDS: f64 = 5.0;

/// Fewest lines either side of a root that its window holds.
pub const MIN_HALF_WIDTH: usize = 20;

/// Block means per half-power band B.
const BLOCKS_PER_BAND: f64 = 8.0;

/// Largest lag, in half-power bands B: a(4B) = 1/17.
const MAX_LAG_BANDS: f64 = 4.0;

/// Residuals of a fit on some channels (each over every line), for the
/// inflation of each root's ΔRSS.
pub struct ResidualCorrelation {
    residuals: Vec<Vec<Complex64>>,
}

impl ResidualCorrelation {
    /// From the residuals of the channels to pool (equal lengths).
    pub fn new(residuals: Vec<Vec<Complex64>>) -> ResidualCorrelation {
        ResidualCorrelation { residuals }
    }

    fn n_lines(&self) -> usize {
        self.residuals.first().map_or(0, Vec::len)
    }

    /// The variance inflation I ≥ 1 of the ΔRSS of a root at line `centre`
    /// (fractional) whose half-power band is `bandwidth_lines` wide: the
    /// part of Î the window can tell from white noise (module docs).
    pub fn inflation(&self, centre: f64, bandwidth_lines: f64) -> f64 {
        let (estimate, se) = self.estimate(centre, bandwidth_lines);
        1.0 + (estimate - 1.0 - 2.0 * se).max(0.0)
    }

    /// Î pooled over the channels and its standard error under white noise.
    pub fn estimate(&self, centre: f64, bandwidth_lines: f64) -> (f64, f64) {
        let n = self.n_lines();
        let b = bandwidth_lines;
        if n < 3 || !(b > 0.0 && b.is_finite()) || !centre.is_finite() {
            return (1.0, 0.0);
        }
        let half = ((HALF_WIDTH_BANDS * b).ceil() as usize).max(MIN_HALF_WIDTH);
        let c = centre.round().clamp(0.0, (n - 1) as f64) as usize;
        let (lo, hi) = (c.saturating_sub(half), (c + half + 1).min(n));
        let d = ((b / BLOCKS_PER_BAND).floor() as usize).max(1);
        let n_blocks = (hi - lo) / d;
        if n_blocks < 2 {
            return (1.0, 0.0);
        }
        let max_lag = ((MAX_LAG_BANDS * b / d as f64).ceil() as usize).min(n_blocks - 1);
        let a: Vec<f64> = (1..=max_lag)
            .map(|k| 1.0 / (1.0 + ((k * d) as f64 / b).powi(2)))
            .collect();
        let per_channel: Vec<f64> = self
            .residuals
            .iter()
            .filter_map(|r| channel_estimate(&r[lo..lo + n_blocks * d], d, &a))
            .collect();
        if per_channel.is_empty() {
            return (1.0, 0.0);
        }
        let m = per_channel.len() as f64;
        let estimate = per_channel.iter().sum::<f64>() / m;
        let se = 2.0 * (a.iter().map(|x| x * x).sum::<f64>() / n_blocks as f64 / m).sqrt();
        (estimate, se)
    }
}

/// Î of one channel's residual `r` (whole blocks of `d` lines) for the
/// column autocorrelations `a` at block lags 1, 2, …; `None` without power.
fn channel_estimate(r: &[Complex64], d: usize, a: &[f64]) -> Option<f64> {
    let y: Vec<Complex64> = r
        .chunks_exact(d)
        .map(|b| b.iter().sum::<Complex64>() / d as f64)
        .collect();
    let gamma_r0 = r.iter().map(Complex64::norm_sqr).sum::<f64>() / r.len() as f64;
    if gamma_r0.is_nan() || gamma_r0 <= 0.0 {
        return None;
    }
    let n = y.len() as f64;
    let gamma = |k: usize| -> f64 {
        y.iter()
            .zip(&y[k..])
            .map(|(u, v)| (u * v.conj()).re)
            .sum::<f64>()
            / n
    };
    let long_run = gamma(0)
        + 2.0
            * a.iter()
                .enumerate()
                .map(|(i, w)| w * gamma(i + 1))
                .sum::<f64>();
    Some(d as f64 * long_run / gamma_r0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::synthetic::gauss;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn white(n: usize, seed: u64) -> Vec<Complex64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Complex64::new(gauss(&mut rng), gauss(&mut rng)))
            .collect()
    }

    #[test]
    fn white_residuals_leave_the_test_as_it_was() {
        // Î scatters about 1 by se/2; only what exceeds 1 + 2 se inflates.
        let c = ResidualCorrelation::new((0..16).map(|s| white(4000, s)).collect());
        for b in [0.5, 3.0, 20.0, 200.0] {
            let (i, se) = c.estimate(2000.0, b);
            assert!(se > 0.0 && (i - 1.0).abs() < 1.5 * se, "B {b}: {i} ± {se}");
            assert!(c.inflation(2000.0, b) < 1.0 + 0.5 * se, "B {b}");
        }
    }

    #[test]
    fn a_smooth_residual_inflates_by_the_sum_of_the_columns_autocorrelation() {
        // Smooth over far more lines than the root's band (ρ ≈ 1 up to the
        // largest lag 4B), against the same sum line by line: the biased
        // estimate over a window of W = 2·max(5B, 20) + 1 lines gives
        // I = 1 + 2 Σ_{j=1}^{4B} (1 − j/W)/(1 + (j/B)²).
        let smooth: Vec<Complex64> = (0..4000)
            .map(|f| Complex64::from_polar(1.0, f as f64 * 1e-4))
            .collect();
        let c = ResidualCorrelation::new(vec![smooth]);
        for b in [2.0f64, 10.0, 40.0] {
            let w = 2.0 * (5.0 * b).max(20.0) + 1.0;
            let exact = 1.0
                + 2.0
                    * (1..=(4.0 * b) as usize)
                        .map(|j| (1.0 - j as f64 / w) / (1.0 + (j as f64 / b).powi(2)))
                        .sum::<f64>();
            let (i, _) = c.estimate(2000.0, b);
            assert!((i / exact - 1.0).abs() < 0.1, "B {b}: {i} vs {exact}");
            assert!(c.inflation(2000.0, b) > 0.5 * exact, "B {b}");
        }
    }

    #[test]
    fn a_lag_one_correlation_doubles_the_variance_of_a_broad_root() {
        // Moving average of white noise: ρ(1) = 1/2, ρ(j ≥ 2) = 0, so
        // I = 1 + 2 · (1/2)/(1 + 1/B²) ≈ 2 for B = 40 (blocks of 5 lines).
        let ma = |s| -> Vec<Complex64> { white(4001, s).windows(2).map(|p| p[0] + p[1]).collect() };
        let c = ResidualCorrelation::new((0..16).map(ma).collect());
        let (i, se) = c.estimate(2000.0, 40.0);
        assert!((i - 2.0).abs() < 0.25 && se < 0.2, "{i} ± {se}");
        let inflated = c.inflation(2000.0, 40.0);
        assert!((inflated - (i - 2.0 * se)).abs() < 1e-12, "{inflated}");
    }
}
