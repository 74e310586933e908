//! The uncertainty of a reference mode: the standard deviations that scale
//! its residuals, so that each residual counts in units of its own noise.
//!
//! Frequencies are far more precise than shapes: an EMA estimates a
//! well-excited mode's frequency to a few 0.1 ‰ from the whole band of its
//! peak, its shape from one residue per sensor, each carrying that sensor's
//! noise. Without information from the reference itself (a stabilization
//! spread, a noise level), the defaults are those of a careful EMA of a
//! machine tool with 1–2 % FRF noise: σ_f = 0.2 % of the frequency, and
//! σ_s = 0.02 per component of the unit-normalized shape — at ten sensors a
//! shape error ‖δψ‖² = 20 σ_s² = 0.008, i.e. MAC ≈ 0.992. With these, a 1 %
//! frequency error weighs as much as a MAC of 0.99. Modal damping is the
//! least certain estimate of all (σ_ζ = 10 % of the damping ratio); it only
//! enters the identifiability analysis of damping parameters — the
//! stiffness is fitted to frequencies and shapes (PUB3).
//!
//! **From the estimate itself** (`from_complexity`, on by default): the model
//! is proportionally damped, so its shapes are real; an identified shape's
//! imaginary part, after the rotation that makes it most real, is error —
//! and in isotropic noise its real part carries as much. Its RMS per
//! component, c_r, is therefore a per-mode estimate of the shape noise, and
//! a mode is given σ_s,r = max(σ_s, c_r). A large c_r marks an estimate that
//! mixed two modes (two close, well-damped modes fitted as one), whose
//! frequency is no better than its shape: such a mode gets
//! σ_f,r = σ_f · max(1, c_r/σ_s). Measured on AutoEMA modes of the test
//! bench with 1 % FRF noise, c_r tracks the shape error: MAC with the true
//! shape 0.999+ at c < 0.01, 0.93 at c = 0.07, 0.46–0.54 at c = 0.1–0.17.

//!
//! **As the estimate states it** (`from_estimate`, on by default): a
//! reference that says how well it knows each mode (`uncertainty.csv` of a
//! `modes` artifact; AutoEMA writes its stable columns' robust spread) has
//! σ_f,r raised to what that spread implies, and σ_s,r by the same factor over the
//! default: a column that gathered poles of two modes, or whose pole the
//! FRF refinement moved off the column, scatters by percents where a clean
//! mode's agrees to 0.1 ‰, and its LSFD shape is then a mixture too.
//! The spread is calibrated to a standard deviation by [`SPREAD_TO_SIGMA`]:
//! on 393 AutoEMA modes of the test bench (20 truths, 1 % FRF noise and
//! simulated impact tests), the median frequency error against the truth
//! is 0.5–0.7 of the spread in every bin from 0.1 % to 3 % (so σ ≈ 0.6 ×
//! spread), and the median MAC with the true shape falls with it: 1.000
//! below 0.1 %, 0.975 at 0.2–0.8 %, 0.93 at 0.8–1.5 %, 0.33 above 3 %
//! (columns that gathered two modes).

/// The standard deviation of a frequency (or damping) estimate per unit
/// of its AutoEMA column's robust spread (module docs).
pub const SPREAD_TO_SIGMA: f64 = 0.6;

/// Standard deviations of one reference mode.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Uncertainty {
    /// Relative standard deviation of the natural frequency.
    pub frequency: f64,
    /// Standard deviation of one component (real or imaginary part) of the
    /// unit-normalized shape.
    pub shape: f64,
    /// Relative standard deviation of the damping ratio.
    pub damping: f64,
    /// Raise each mode's σ_s (and σ_f) by its shape's complexity.
    pub from_complexity: bool,
    /// Raise each mode's σ_f and σ_s to the spread the reference states
    /// (`uncertainty.csv`), when it states one.
    pub from_estimate: bool,
}

impl Default for Uncertainty {
    fn default() -> Self {
        Uncertainty {
            frequency: 2e-3,
            shape: 2e-2,
            damping: 0.1,
            from_complexity: true,
            from_estimate: true,
        }
    }
}

impl Uncertainty {
    /// Check the values; the message names the bad one.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("frequency", self.frequency),
            ("shape", self.shape),
            ("damping", self.damping),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!(
                    "uncertainty.{name} = {v} must be a positive standard deviation"
                ));
            }
        }
        Ok(())
    }
}

/// Setting the reference modes' standard deviations.
impl super::ModalObjective {
    /// Give every reference mode the uncertainty `u`, raised per mode by its
    /// shape's complexity when `u.from_complexity` (see [`Uncertainty`]).
    pub fn set_uncertainty(&mut self, u: Uncertainty) {
        for r in &mut self.references {
            for k in 0..r.frequencies.len() {
                let c = if u.from_complexity {
                    complexity(&r.shapes[k])
                } else {
                    0.0
                };
                r.sigma_s[k] = u.shape.max(c);
                r.sigma_f[k] = u.frequency * (c / u.shape).max(1.0);
                r.sigma_z[k] = u.damping;
            }
        }
    }

    /// Raise the uncertainty of mode `mode` (0-based) of reference position
    /// `position` to what the estimate states about itself: the relative
    /// spreads `frequency` and `damping` of an AutoEMA column, taken as
    /// standard deviations through [`SPREAD_TO_SIGMA`]. A mode whose frequency is k = σ_f,r/σ_f times less certain
    /// than the default is taken to be k times less certain in its shape
    /// too (see [`Uncertainty`]); the defaults `u` stay the floor. Unknown
    /// positions and modes are ignored (the reference may have been cut to
    /// `positions`).
    pub fn raise_uncertainty(
        &mut self,
        u: &Uncertainty,
        position: u32,
        mode: usize,
        frequency: f64,
        damping: f64,
    ) {
        let Some(r) = self
            .references
            .iter_mut()
            .find(|r| r.position.index == position)
        else {
            return;
        };
        if mode >= r.frequencies.len() {
            return;
        }
        let to_sigma = SPREAD_TO_SIGMA;
        r.sigma_f[mode] = r.sigma_f[mode].max(to_sigma * frequency);
        let k = r.sigma_f[mode] / u.frequency;
        r.sigma_s[mode] = r.sigma_s[mode].max(u.shape * k);
        r.sigma_z[mode] = r.sigma_z[mode].max(to_sigma * damping);
    }

    /// The standard deviations (relative frequency, shape component) of
    /// reference mode `r` at slot `p`.
    pub fn uncertainty_of(&self, p: usize, r: usize) -> (f64, f64) {
        (self.references[p].sigma_f[r], self.references[p].sigma_s[r])
    }
}

/// The RMS per DOF of the imaginary part of the unit-normalized `shape`
/// after the rotation e^{−jθ} that makes it most real (θ = ½ arg Σ ψ_i²):
/// 0 for a real (normal-mode) shape.
pub fn complexity(shape: &[num_complex::Complex64]) -> f64 {
    let norm = shape.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
    if norm == 0.0 || shape.is_empty() {
        return 0.0;
    }
    let sum: num_complex::Complex64 = shape.iter().map(|v| v * v).sum();
    let rot = num_complex::Complex64::from_polar(1.0 / norm, -0.5 * sum.arg());
    let im2: f64 = shape.iter().map(|v| (v * rot).im.powi(2)).sum();
    (im2 / shape.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;

    #[test]
    fn complexity_is_zero_for_rotated_real_shapes_and_measures_the_rest() {
        let real = [1.0, -0.5, 0.25, 0.8];
        let rot = Complex64::from_polar(2.0, 1.1);
        let shape: Vec<Complex64> = real.iter().map(|&v| rot * v).collect();
        assert!(complexity(&shape) < 1e-15);
        // (1, j)/√2 cannot be rotated real: each component keeps
        // imaginary part ½ after the best rotation (θ = 0 or π/2 tie).
        let q = [Complex64::new(1.0, 0.0), Complex64::new(0.0, 1.0)];
        assert!((complexity(&q) - 0.5).abs() < 1e-12, "{}", complexity(&q));
        assert_eq!(complexity(&[]), 0.0);
    }
}
