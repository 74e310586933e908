//! Which model modes the sensors can see at all: a mode whose shape at the
//! sensors is rounding noise (an in-plane mode of a structure measured out
//! of plane) must never pair with a reference mode.

use crate::modal::Mode;
use num_complex::Complex64;

/// A model mode whose mass-normalized shape at the sensors is below this
/// fraction of the largest (in amplitude) does not move them at all: an
/// in-plane mode of a structure measured out of plane (10⁻¹⁴ against 1 on
/// the real beam). Its shape there is rounding noise, and the MAC of noise
/// with a measured shape is random (0.5 and more at 30 sensors), so it
/// could pair with a reference mode inside the window.
const INVISIBLE: f64 = 1e-6;

/// Zero the sensor shapes of modes the sensors cannot see ([`INVISIBLE`]):
/// MAC with a zero shape is 0, so they never pair.
pub(super) fn mask_invisible(modes: &mut [Mode]) {
    let norm = |m: &Mode| m.shape.iter().map(|c| c.norm_sqr()).sum::<f64>();
    let max = modes.iter().map(norm).fold(0.0, f64::max);
    for m in modes.iter_mut() {
        if norm(m) <= INVISIBLE * INVISIBLE * max {
            m.shape
                .iter_mut()
                .for_each(|c| *c = Complex64::new(0.0, 0.0));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mode that moves the sensors 10⁻¹⁴ as much as the others is masked
    /// (MAC 0 with anything), one at 10⁻³ is kept.
    #[test]
    fn invisible_model_modes_cannot_pair() {
        let mode = |a: f64| Mode {
            frequency_hz: 100.0,
            damping_ratio: 0.01,
            shape: vec![Complex64::new(a, 0.0), Complex64::new(-a, a)],
        };
        let mut modes = vec![mode(1.0), mode(1e-14), mode(1e-3)];
        mask_invisible(&mut modes);
        let reference = [Complex64::new(1.0, 0.0), Complex64::new(-1.0, 1.0)];
        assert_eq!(crate::metrics::mac(&reference, &modes[1].shape), 0.0);
        assert!(crate::metrics::mac(&reference, &modes[0].shape) > 0.99);
        assert!(crate::metrics::mac(&reference, &modes[2].shape) > 0.99);
    }
}
