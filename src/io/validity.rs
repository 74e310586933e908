//! Physical validity of measured values, shared by every reader (UFF 58/58b,
//! CSV FRF, CSV modal): a frequency line is finite and ≥ 0 (exactly 0 is a
//! valid DC line) and each line of an axis is strictly greater than the one
//! before; a coherence γ² is a number in [0, 1]. Readers call these as they
//! read, so the error names the file and the line (or byte) of the value.
//! The functions return the problem as text; the reader adds the location.

/// One frequency line after `previous` (the line before it on the same
/// axis, if any): finite, ≥ 0 and strictly greater than `previous`.
pub fn check_frequency(f: f64, previous: Option<f64>) -> Result<(), String> {
    if !f.is_finite() {
        return Err(format!(
            "frequency {f} is not finite; replace NaN/inf values before importing"
        ));
    }
    if f < 0.0 {
        return Err(format!(
            "frequency {f} is negative; measured frequency lines are ≥ 0 (0 itself is allowed), \
             fix the export's frequency axis"
        ));
    }
    match previous {
        Some(p) if f <= p => Err(format!(
            "frequency {f} does not increase (the line before is {p}); frequency lines must be \
             strictly increasing, remove duplicates or sort the lines"
        )),
        _ => Ok(()),
    }
}

/// A whole axis: the index of the first bad line and the problem.
pub fn check_abscissa(frequencies: &[f64]) -> Result<(), (usize, String)> {
    let mut previous = None;
    for (i, &f) in frequencies.iter().enumerate() {
        check_frequency(f, previous).map_err(|m| (i, m))?;
        previous = Some(f);
    }
    Ok(())
}

/// An evenly spaced axis `start + i · step`, `i < points`: start ≥ 0, and,
/// with two points or more, step > 0 and a finite last line that the step
/// still moves.
pub fn check_even_abscissa(start: f64, step: f64, points: usize) -> Result<(), String> {
    check_frequency(start, None).map_err(|m| format!("abscissa minimum: {m}"))?;
    if points < 2 {
        return Ok(());
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(format!(
            "abscissa increment {step} is not positive; frequency lines must be strictly \
             increasing, fix the export's frequency axis"
        ));
    }
    let last = start + (points - 1) as f64 * step;
    if !last.is_finite() || start + step <= start {
        return Err(format!(
            "abscissa minimum {start} and increment {step} give no increasing axis of {points} \
             lines in double precision"
        ));
    }
    Ok(())
}

/// What a reader does with a coherence γ² outside [0, 1] (the import's
/// `coherence` param). Readers take it only to decide what they *accept*
/// (so a value nothing can excuse stays an error at its line); clamping
/// itself is [`clamp_coherence`] on the FRF sets, one place for every
/// format, where frequencies are in Hz and FRFs are known.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CoherencePolicy {
    /// Refuse a value outside [0, 1].
    #[default]
    Check,
    /// Accept values in [[`CLAMP_BELOW`], [`CLAMP_LIMIT`]], to be clamped
    /// to [0, 1]; refuse values beyond (and NaN/inf).
    Clamp,
    /// Do not check coherence values; the caller drops them.
    Ignore,
}

/// The largest γ² that `clamp` turns into 1. γ² = |G_xy|²/(G_xx G_yy) ≤ 1
/// for any consistent estimate; analysers' overlap processing, window
/// corrections and rounding push it above 1 at lines of low signal, by a
/// fraction (vibration-toolbox case 1: 1.246 at 0 Hz). A value above 2
/// is not such an artefact but a column that is not γ² on the 0–1 scale
/// (a percentage, dB, a shifted column); clamping it would hide that.
pub const CLAMP_LIMIT: f64 = 2.0;

/// The lowest γ² that `clamp` turns into 0. No estimator of a ratio of
/// non-negative spectra goes below 0; only rounding or an exporter's
/// `1 − x` does, by little (values printed with two decimals: −0.01).
/// Anything lower is a wrong column, as above [`CLAMP_LIMIT`].
pub const CLAMP_BELOW: f64 = -0.01;

/// How to fix a coherence outside [0, 1], for the messages below.
const FIX: &str = "fix the export, or set `coherence: clamp` (values in [-0.01, 2] become 0 or 1) \
                   or `coherence: ignore` (coherence not read) in the import params";

/// A coherence value γ²: a number in [0, 1] (NaN refused).
pub fn check_coherence(c: f64) -> Result<(), String> {
    check_coherence_with(c, CoherencePolicy::Check)
}

/// A coherence value γ² as `policy` accepts it: in [0, 1] (`Check`), in
/// [[`CLAMP_BELOW`], [`CLAMP_LIMIT`]] (`Clamp`), anything (`Ignore`).
pub fn check_coherence_with(c: f64, policy: CoherencePolicy) -> Result<(), String> {
    match policy {
        CoherencePolicy::Ignore => Ok(()),
        _ if (0.0..=1.0).contains(&c) => Ok(()),
        CoherencePolicy::Check => Err(format!(
            "coherence {c} is outside [0, 1]; γ² is a ratio of spectra between 0 and 1: {FIX}"
        )),
        CoherencePolicy::Clamp if (CLAMP_BELOW..=CLAMP_LIMIT).contains(&c) => Ok(()),
        CoherencePolicy::Clamp => Err(format!(
            "coherence {c} is outside [{CLAMP_BELOW}, {CLAMP_LIMIT}], too far from [0, 1] to \
             clamp: not a γ² on the 0–1 scale (a percentage? dB?); fix the export, or set \
             `coherence: ignore` in the import params"
        )),
    }
}

/// What [`clamp_coherence`] changed: lines (values) in FRFs (channels of
/// a position), the extreme values and the frequency range of those lines.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CoherenceClamps {
    pub lines: usize,
    pub frfs: usize,
    pub largest: f64,
    pub smallest: f64,
    pub band_hz: [f64; 2],
}

impl CoherenceClamps {
    /// The stage warning: one sentence for all files.
    pub fn warning(&self) -> String {
        let below = if self.smallest < 0.0 {
            format!(", smallest {}", self.smallest)
        } else {
            String::new()
        };
        format!(
            "coherence outside [0, 1] clamped (`coherence: clamp`) on {} line(s) in {} FRF(s), \
             {}–{} Hz: largest value {}{below}",
            self.lines, self.frfs, self.band_hz[0], self.band_hz[1], self.largest
        )
    }
}

/// Clamps every coherence of `sets` to [0, 1]; what was changed, `None`
/// when nothing was. Readers with [`CoherencePolicy::Clamp`] have refused
/// values beyond [[`CLAMP_BELOW`], [`CLAMP_LIMIT`]] and NaN.
pub fn clamp_coherence(sets: &mut [crate::frf::FrfSet]) -> Option<CoherenceClamps> {
    let mut out: Option<CoherenceClamps> = None;
    for s in sets.iter_mut() {
        for c in &mut s.channels {
            let Some(coherence) = c.coherence.as_mut() else {
                continue;
            };
            let mut touched = false;
            for (g, &f) in coherence.iter_mut().zip(&s.frequencies_hz) {
                if (0.0..=1.0).contains(g) {
                    continue;
                }
                let o = out.get_or_insert(CoherenceClamps {
                    lines: 0,
                    frfs: 0,
                    largest: *g,
                    smallest: *g,
                    band_hz: [f, f],
                });
                o.lines += 1;
                o.frfs += usize::from(!touched);
                o.largest = o.largest.max(*g);
                o.smallest = o.smallest.min(*g);
                o.band_hz = [o.band_hz[0].min(f), o.band_hz[1].max(f)];
                touched = true;
                *g = g.clamp(0.0, 1.0);
            }
        }
    }
    out
}

/// A natural frequency of a mode: finite and ≥ 0.
pub fn check_natural_frequency(f: f64) -> Result<(), String> {
    if f.is_finite() && f >= 0.0 {
        Ok(())
    } else {
        Err(format!(
            "natural frequency {f} Hz is not a finite number ≥ 0; fix the modal model"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequencies_must_be_non_negative_and_increasing() {
        assert!(check_abscissa(&[0.0, 0.5, 1.0]).is_ok());
        assert!(check_abscissa(&[]).is_ok());
        let (i, m) = check_abscissa(&[1.0, -2.0]).unwrap_err();
        assert_eq!(i, 1);
        assert!(m.contains("negative"), "{m}");
        let (i, m) = check_abscissa(&[1.0, 2.0, 2.0]).unwrap_err();
        assert_eq!(i, 2);
        assert!(m.contains("does not increase"), "{m}");
        assert!(check_abscissa(&[f64::NAN]).is_err());
        assert!(check_frequency(-0.0, None).is_ok());
    }

    #[test]
    fn even_axes_need_a_start_at_or_above_zero_and_a_positive_step() {
        assert!(check_even_abscissa(0.0, 0.25, 100).is_ok());
        assert!(check_even_abscissa(5.0, 0.0, 1).is_ok());
        assert!(check_even_abscissa(-1.0, 0.25, 100).is_err());
        assert!(check_even_abscissa(1.0, 0.0, 2).is_err());
        assert!(check_even_abscissa(1.0, -0.5, 2).is_err());
        assert!(check_even_abscissa(1e20, 1e-10, 2).is_err());
        assert!(check_even_abscissa(0.0, 1e308, 10).is_err());
    }

    #[test]
    fn coherence_is_between_zero_and_one() {
        for c in [0.0, 0.5, 1.0] {
            assert!(check_coherence(c).is_ok());
        }
        for c in [7.0, -1e-12, 1.0 + 1e-12, f64::NAN, f64::INFINITY] {
            let e = check_coherence(c).unwrap_err();
            assert!(e.contains("`coherence: clamp`"), "{e}");
        }
        assert!(check_natural_frequency(0.0).is_ok());
        assert!(check_natural_frequency(-1.0).is_err());
    }

    #[test]
    fn clamp_accepts_a_margin_and_refuses_the_rest() {
        let clamp = |c| check_coherence_with(c, CoherencePolicy::Clamp);
        for c in [0.0, 1.0, 1.246, CLAMP_LIMIT, -0.005, CLAMP_BELOW] {
            assert!(clamp(c).is_ok(), "{c}");
        }
        for c in [
            2.0 + 1e-9,
            100.0,
            -0.02,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            let e = clamp(c).unwrap_err();
            assert!(
                e.contains("too far") && e.contains("`coherence: ignore`"),
                "{c}: {e}"
            );
        }
        for c in [7.0, -3.0, f64::NAN] {
            assert!(
                check_coherence_with(c, CoherencePolicy::Ignore).is_ok(),
                "{c}"
            );
        }
    }

    #[test]
    fn clamping_counts_lines_frfs_extremes_and_band() {
        use crate::frf::{Dof, FrfChannel, FrfSet};
        let channel = |n: u32, coherence: Option<Vec<f64>>| FrfChannel {
            response: Dof::new(n, 3),
            reference: Dof::new(1, 3),
            values: vec![Default::default(); 4],
            coherence,
        };
        let mut sets = vec![FrfSet {
            frequencies_hz: vec![0.0, 2.5, 5.0, 7.5],
            channels: vec![
                channel(2, Some(vec![1.2, 0.5, 1.0, 1.5])),
                channel(3, Some(vec![0.1, -0.004, 0.3, 0.4])),
                channel(4, Some(vec![0.2; 4])),
                channel(5, None),
            ],
            ..FrfSet::default()
        }];
        let c = clamp_coherence(&mut sets).unwrap();
        assert_eq!((c.lines, c.frfs), (3, 2));
        assert_eq!(
            (c.largest, c.smallest, c.band_hz),
            (1.5, -0.004, [0.0, 7.5])
        );
        let ch = &sets[0].channels;
        assert_eq!(ch[0].coherence.as_deref(), Some(&[1.0, 0.5, 1.0, 1.0][..]));
        assert_eq!(ch[1].coherence.as_deref(), Some(&[0.1, 0.0, 0.3, 0.4][..]));
        let w = c.warning();
        assert!(
            w.contains("3 line(s) in 2 FRF(s)") && w.contains("1.5"),
            "{w}"
        );
        assert!(clamp_coherence(&mut sets).is_none(), "already in [0, 1]");
    }
}
