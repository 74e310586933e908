//! The worst local misfit of an FRF fit: the overall RMS in noise units
//! dilutes a resonance the model misses or misplaces (issue 26, identify
//! 22); the verdict judges this window too ([`super::verdict`]).

/// The worst misfit over [`LOCAL_LINES`] consecutive lines of one position,
/// pooled over its channels: the RMS in noise units (1 at the noise) over
/// that window. The overall RMS dilutes a resonance the model misses or
/// misplaces (a lightly damped mode is a few lines wide among thousands,
/// and the robust cost lets the optimizer give up on it); over its own
/// lines the misfit is tens of σ. Under noise alone the window holds
/// 2 · 9 · n_ch unit-variance parts, so its RMS stays below ≈ 1.6 even
/// with one channel over 10⁴ windows (χ²₁₈'s 99.99 % point is 45.9).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LocalMisfit {
    pub rms: f64,
    /// Centre line of the window, Hz.
    pub frequency_hz: f64,
    /// Position index of the FRF set.
    pub position: u32,
}

/// Lines in the window of [`LocalMisfit`].
pub const LOCAL_LINES: usize = 9;

impl LocalMisfit {
    /// The worst window of one position from its per-line Σ_c |d_c|² over
    /// `channels` channels; `None` with fewer lines than a window.
    pub(super) fn worst(
        position: u32,
        lines_hz: &[f64],
        power: &[f64],
        channels: usize,
    ) -> Option<Self> {
        if power.len() < LOCAL_LINES || channels == 0 {
            return None;
        }
        let scale = 1.0 / (2.0 * (LOCAL_LINES * channels) as f64);
        let mut sum: f64 = power[..LOCAL_LINES].iter().sum();
        let mut best = (sum, 0);
        for start in 1..=power.len() - LOCAL_LINES {
            sum += power[start + LOCAL_LINES - 1] - power[start - 1];
            if sum > best.0 {
                best = (sum, start);
            }
        }
        let rms = (best.0.max(0.0) * scale).sqrt();
        rms.is_finite().then_some(LocalMisfit {
            rms,
            frequency_hz: lines_hz[best.1 + LOCAL_LINES / 2],
            position,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The window's arithmetic on a known spike: 9 lines, one channel, 9·2
    /// unit parts at the noise and one line of |d|² = 2·(81 + 1).
    #[test]
    fn the_worst_window_of_a_known_spike() {
        let mut power = vec![2.0; 40];
        power[20] = 2.0 * 82.0;
        let lines: Vec<f64> = (0..40).map(|k| k as f64).collect();
        let w = LocalMisfit::worst(3, &lines, &power, 1).unwrap();
        assert!(
            (w.rms - (1.0f64 + 81.0 / 9.0).sqrt()).abs() < 1e-12,
            "{w:?}"
        );
        assert_eq!(
            (w.position, (w.frequency_hz - 20.0).abs() <= 4.0),
            (3, true)
        );
        // At the noise: 1.
        let flat = LocalMisfit::worst(0, &lines, &[2.0; 40], 1).unwrap();
        assert!((flat.rms - 1.0).abs() < 1e-12, "{flat:?}");
        assert!(LocalMisfit::worst(0, &lines[..8], &power[..8], 1).is_none());
    }
}
