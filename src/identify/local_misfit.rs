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

use super::correspondence::NOT_OBSERVABLE;
use super::objective::ModeUse;
use super::ModalObjective;

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

impl LocalMisfit {
    /// What the modal reference holds in this window's lines `lo_hz..=hi_hz`
    /// (a warning beside a window far above the noise): each reference mode
    /// of the position there, and whether the modal fit used it or why not
    /// — or that there is none, so the FRFs alone place the modes there.
    /// On the vertical mill the failures' windows sit on pairs of modes a
    /// quarter line wide (ζ ≈ 0.06 %) that AutoEMA finds one of, or none,
    /// and that the correspondence leaves out as barely observable
    /// (docs/uncertainty.md).
    pub(super) fn reference_note(&self, o: &ModalObjective, (lo_hz, hi_hz): (f64, f64)) -> String {
        let head = format!(
            "the FRFs' worst window ({lo_hz:.2}–{hi_hz:.2} Hz at position {}, {:.0}σ)",
            self.position, self.rms
        );
        let Some(p) = o.slot(self.position) else {
            return format!("{head} lies at a position without reference modes");
        };
        let inside: Vec<(usize, f64, &ModeUse)> = (0..o.modes_at(p))
            .map(|r| (r, o.reference_frequency(p, r), o.mode_use(p, r)))
            .filter(|(_, f, _)| (lo_hz..=hi_hz).contains(f))
            .collect();
        if inside.is_empty() {
            return format!(
                "{head} holds no reference mode: the EMA found none there, so the FRFs alone place the modes there"
            );
        }
        let weak = inside.iter().any(
            |(_, _, u)| matches!(u, ModeUse::Excluded(why) if why.starts_with(NOT_OBSERVABLE)),
        );
        let hint = if weak {
            "; a lower `observability` lets a mode the sensors see weakly count (by its frequency alone below `shape_observability`)"
        } else {
            ""
        };
        let modes: Vec<String> = inside
            .iter()
            .map(|&(r, f, u)| {
                let how = match u {
                    ModeUse::Full => "used by the modal fit".to_string(),
                    ModeUse::FrequencyOnly(why) => format!("used by the modal fit, {why}"),
                    ModeUse::Excluded(why) => format!("left out of the modal fit: {why}"),
                };
                format!("reference mode {} ({f:.2} Hz), {how}", r + 1)
            })
            .collect();
        format!("{head} holds {}{hint}", modes.join("; "))
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

    /// The note names the reference modes inside the window with their
    /// status (a mode compared by frequency alone says so), the
    /// `observability` hint only for a mode left out as not observable, and
    /// says so when the window holds none.
    #[test]
    fn the_note_says_what_the_reference_holds_in_the_window() {
        let mut o = crate::identify::black_box::tests::objective();
        let position = o.position(0).index;
        let f1 = o.reference_frequency(0, 1);
        let window = (f1 - 0.5, f1 + 0.5);
        let w = LocalMisfit {
            rms: 15.0,
            frequency_hz: f1,
            position,
        };
        let used = w.reference_note(&o, window);
        assert!(
            used.contains("reference mode 2") && used.contains("used by the modal fit"),
            "{used}"
        );
        assert!(!used.contains("observability"), "{used}");
        let mut weak = crate::identify::black_box::tests::objective();
        weak.compare_frequency_only(0, 1, "frequency only, shape not observable: 0.2×");
        let by_frequency = w.reference_note(&weak, window);
        assert!(
            by_frequency.contains("used by the modal fit, frequency only, shape not observable"),
            "{by_frequency}"
        );
        o.exclude(
            0,
            1,
            format!("{NOT_OBSERVABLE}: its model mode moves the sensors 0.13×"),
        );
        let left = w.reference_note(&o, window);
        assert!(
            left.contains("left out of the modal fit: not observable"),
            "{left}"
        );
        assert!(left.contains("a lower `observability`"), "{left}");
        let beside = w.reference_note(&o, (f1 * 10.0, f1 * 10.0 + 1.0));
        assert!(beside.contains("holds no reference mode"), "{beside}");
        let elsewhere = LocalMisfit {
            position: position + 7,
            ..w
        };
        assert!(elsewhere
            .reference_note(&o, window)
            .contains("without reference modes"));
    }
}
