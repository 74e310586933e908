//! Whether a root has a peak of its own in the data: the rule that keeps a
//! pole split off a real mode out of the result, and a separate visible peak
//! in it.
//!
//! Measured FRFs are never exactly one linear time-invariant system: a
//! roving hammer hits each point at another time (temperature, the
//! accelerometer cable, the support), leakage and a coarse line spacing bend
//! a lightly damped peak. A pole pair 0.3–0.7 line spacings apart then fits a
//! single peak better than one pole does, by far more than the noise
//! explains, so significance alone keeps both (the beam of
//! `shared/data/real/beam_ufsc_ss`: 69.0 and 69.7 Hz, 414.7 and 415.3 Hz at
//! 1 Hz lines). A second mode at one peak is real only when the data show
//! it as a mode: its own peak of the first CMIF curve, or a peak of a
//! further CMIF curve there (a second singular value, i.e. a close or
//! repeated root seen by two references; Shih et al. 1988).
//!
//! **The rule.** Each root is assigned to the prominent peak of the first
//! CMIF curve ([`super::noise::cmif_mode_peaks`]) nearest to it within
//! w = max(2 Δf, ζ f) (Δf the line spacing, ζ f the half-power half-width);
//! roots on no peak (shoulders, heavily damped or weak modes) are left to
//! the significance test, unless the data have one reference and a stronger
//! root lies closer than 1.5 line spacings: the two are then one feature of
//! the data, and the weaker is judged as if it shared that root's peak. Of
//! the roots assigned to one peak, the one nearest to it keeps the peak (a
//! broad pole soaking up the flanks of a band must not take a sharp mode's
//! peak; on a tie within a tenth of a line, the one
//! carrying more of the fit, Σ_c ΔRSS_c/σ_c²). Another root on that peak
//! that the data cannot tell from the keeper — closer than 1.5 line
//! spacings, or three times more damped (a broad pole under a sharp peak)
//! — must show a peak of a further CMIF curve within w (a second mode seen by
//! another reference), or it is reported as `same_peak`; a resolvable root of similar damping on the same peak (a
//! close pair seen by one reference) is left to the significance test. Two roots on different peaks are never duplicates.

use super::noise::{cmif_mode_peaks, peak_at};

/// The CMIF peaks of one FRF matrix.
#[derive(Clone, Debug, Default)]
pub struct PeakEvidence {
    /// Frequencies of the prominent peaks of the first CMIF curve, Hz.
    pub peaks_hz: Vec<f64>,
    /// Smallest line spacing, Hz.
    pub step_hz: f64,
    frequencies_hz: Vec<f64>,
    /// CMIF curves 2, 3, … (empty with one reference).
    further: Vec<Vec<f64>>,
}

/// What the rule needs to know of one root.
#[derive(Clone, Copy, Debug)]
pub struct RootPeak {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// Σ_c ΔRSS_c: how much of the fit the root carries.
    pub strength: f64,
    pub multiplicity: usize,
}

impl PeakEvidence {
    /// From the CMIF curves over `frequencies_hz` and the noise power of one
    /// reference column (the floor of [`cmif_mode_peaks`]).
    pub fn new(frequencies_hz: &[f64], cmif: &[Vec<f64>], noise_power: f64) -> PeakEvidence {
        let step_hz = frequencies_hz
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let peaks_hz = cmif.first().map_or_else(Vec::new, |c| {
            cmif_mode_peaks(c, noise_power)
                .into_iter()
                .map(|k| frequencies_hz[k])
                .collect()
        });
        PeakEvidence {
            peaks_hz,
            step_hz: if step_hz.is_finite() { step_hz } else { 0.0 },
            frequencies_hz: frequencies_hz.to_vec(),
            further: cmif.iter().skip(1).cloned().collect(),
        }
    }

    /// Half-width of the window in which a peak belongs to a root, Hz.
    fn window(&self, f: f64, zeta: f64) -> f64 {
        (2.0 * self.step_hz).max(zeta.abs() * f)
    }

    /// Index of the peak a root at `f` belongs to, if any.
    pub fn peak_of(&self, f: f64, zeta: f64) -> Option<usize> {
        let w = self.window(f, zeta);
        self.peaks_hz
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (p - f).abs()))
            .filter(|(_, d)| *d <= w)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// How many further CMIF curves peak at `f` (each a second, third, …
    /// mode there; a merely raised σ₂ is also what two inconsistent columns
    /// give, e.g. references measured in different set-ups).
    pub fn further_curve_peaks(&self, f: f64, zeta: f64) -> usize {
        let hw = (self.window(f, zeta) / 2.0).max(self.step_hz);
        self.further
            .iter()
            .filter(|c| peak_at(c, &self.frequencies_hz, f, hw))
            .count()
    }

    /// Whether two roots sit on different CMIF peaks (then they are two
    /// modes, whatever their shapes).
    pub fn separate(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        match (self.peak_of(a.0, a.1), self.peak_of(b.0, b.1)) {
            (Some(pa), Some(pb)) => pa != pb,
            _ => false,
        }
    }

    /// For every root, the root that keeps its CMIF peak (itself when it
    /// does), or `None` for a root on no peak. The root nearest the peak
    /// keeps it; on a tie within a tenth of a line (a split pair straddling
    /// the peak) the one carrying more of the fit.
    pub fn keepers(&self, roots: &[RootPeak]) -> Vec<Option<usize>> {
        let peak: Vec<Option<usize>> = roots
            .iter()
            .map(|r| self.peak_of(r.frequency_hz, r.damping_ratio))
            .collect();
        let tie = 0.1 * self.step_hz;
        (0..roots.len())
            .map(|k| {
                let p = peak[k]?;
                let f_p = self.peaks_hz[p];
                (0..roots.len())
                    .filter(|&j| peak[j] == Some(p))
                    .min_by(|&a, &b| {
                        let (da, db) = (
                            (roots[a].frequency_hz - f_p).abs(),
                            (roots[b].frequency_hz - f_p).abs(),
                        );
                        if (da - db).abs() <= tie {
                            roots[b].strength.total_cmp(&roots[a].strength)
                        } else {
                            da.total_cmp(&db)
                        }
                        .then(a.cmp(&b))
                    })
            })
            .collect()
    }

    /// Roots that share a peak with the root keeping it (or, with one
    /// reference, lie beside a stronger root off the peaks:
    /// [`Self::stronger_neighbour`]), cannot be told from it by the data
    /// ([`Self::unresolved`]) and have no further CMIF curve peak of their
    /// own to stand on: `(index, index of the keeper)`,
    /// weakest first. Each further curve that peaks at the peak is evidence
    /// for one mode beyond the first, so the unresolved roots there (the
    /// strongest first, after the keeper's own multiplicity) take at most
    /// that many places: with two references no peak holds more than two
    /// modes, however many poles the inconsistent columns of two set-ups
    /// give (the UFSC beam's two tests combined: four roots at 567 Hz).
    pub fn shared_peak_losers(&self, roots: &[RootPeak]) -> Vec<(usize, usize)> {
        let keepers = self.keepers(roots);
        let mut candidates: Vec<(usize, usize)> = keepers
            .iter()
            .enumerate()
            .filter_map(|(k, keeper)| {
                let j = keeper.or_else(|| self.stronger_neighbour(roots, k))?;
                (j != k && roots[k].multiplicity == 1 && self.unresolved(&roots[k], &roots[j]))
                    .then_some((k, j))
            })
            .collect();
        // Strongest first, so the places go to the roots carrying the fit.
        candidates.sort_by(|a, b| {
            roots[b.0]
                .strength
                .total_cmp(&roots[a.0].strength)
                .then(a.0.cmp(&b.0))
        });
        // Further curve peaks at each candidate and at each keeper: a
        // peak holds as many places as the most further curves peaking at
        // any of its roots (a close pair's second curve peaks at the second
        // mode, not at the keeper).
        let count = |r: &RootPeak| self.further_curve_peaks(r.frequency_hz, r.damping_ratio);
        let own: Vec<usize> = candidates.iter().map(|&(k, _)| count(&roots[k])).collect();
        // (keeper, places, places used), each keeper's places counted once.
        let mut groups: Vec<(usize, usize, usize)> = Vec::new();
        let mut losers: Vec<(usize, usize)> = Vec::new();
        for (&(k, j), &n) in candidates.iter().zip(&own) {
            let g = match groups.iter().position(|g| g.0 == j) {
                Some(g) => g,
                None => {
                    let at_group = candidates
                        .iter()
                        .zip(&own)
                        .filter(|((_, q), _)| *q == j)
                        .map(|(_, &n)| n)
                        .max()
                        .unwrap_or(0);
                    let places = count(&roots[j])
                        .max(at_group)
                        .saturating_sub(roots[j].multiplicity.saturating_sub(1));
                    groups.push((j, places, 0));
                    groups.len() - 1
                }
            };
            if n > 0 && groups[g].2 < groups[g].1 {
                groups[g].2 += 1;
            } else {
                losers.push((k, j));
            }
        }
        losers.sort_by(|a, b| roots[a.0].strength.total_cmp(&roots[b.0].strength));
        losers
    }

    /// With one reference, for a root on no CMIF peak, the strongest other
    /// root closer than [`RESOLVABLE_LINES`] line spacings that carries more
    /// of the fit: one column cannot tell two such poles from one mode whose
    /// frequency differs a little from channel to channel (a roving sensor's
    /// mass), so the weaker must earn its place as on a shared peak (the UFSC
    /// shaker test: 274.2 and 274.9 Hz at 1 Hz lines, a weak torsion mode
    /// fitted by two poles). With several references the participation
    /// vectors can separate a close pair off the peaks (the vertical mill's
    /// 54.06/54.59 Hz at 0.5 Hz lines, two references): left to significance.
    fn stronger_neighbour(&self, roots: &[RootPeak], k: usize) -> Option<usize> {
        if !self.further.is_empty() {
            return None;
        }
        let r = &roots[k];
        (0..roots.len())
            .filter(|&j| {
                j != k
                    && (roots[j].frequency_hz - r.frequency_hz).abs()
                        < RESOLVABLE_LINES * self.step_hz
                    && roots[j].strength > r.strength
            })
            .max_by(|&a, &b| roots[a].strength.total_cmp(&roots[b].strength))
    }

    /// Whether root `r` on the peak of `keeper` is no mode of its own in a
    /// single CMIF curve: closer than [`RESOLVABLE_LINES`] line spacings
    /// (no line between them for a valley), or [`BROADER`] times more
    /// damped (a broad pole under a sharp peak fits its flanks and the
    /// leakage, not a mode). Other roots on a shared peak, resolvable and
    /// alike, are left to the significance test (a close pair of similar
    /// damping, seen by one reference).
    fn unresolved(&self, r: &RootPeak, keeper: &RootPeak) -> bool {
        (r.frequency_hz - keeper.frequency_hz).abs() < RESOLVABLE_LINES * self.step_hz
            || r.damping_ratio > BROADER * keeper.damping_ratio
    }
}

/// Pairs of roots closer than [`RESOLVABLE_LINES`] line spacings (both
/// kept, so a further CMIF curve peaks there), as frequency pairs. Several
/// of them mean the references do not share their poles: each column has
/// its own version of the mode (references measured in different set-ups,
/// mass loading that moves with the hammer or shaker, a structure that
/// changed during the test).
pub fn unresolved_pairs(step_hz: f64, frequencies_hz: &[f64]) -> Vec<(f64, f64)> {
    frequencies_hz
        .windows(2)
        .filter(|w| (w[1] - w[0]).abs() < RESOLVABLE_LINES * step_hz)
        .map(|w| (w[0], w[1]))
        .collect()
}

/// Separation in line spacings below which two poles on one peak cannot be
/// two peaks of the data.
pub const RESOLVABLE_LINES: f64 = 1.5;

/// Damping ratio multiple from which a pole on a sharper mode's peak is a
/// broad pole fitting its flanks.
pub const BROADER: f64 = 3.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// Lorentzian-like peaks |1/(f_r² − f² + 2iζ f_r f)| summed, on `freqs`.
    fn curve(freqs: &[f64], modes: &[(f64, f64, f64)]) -> Vec<f64> {
        freqs
            .iter()
            .map(|&f| {
                modes
                    .iter()
                    .map(|&(fr, z, a)| {
                        let re = fr * fr - f * f;
                        let im = 2.0 * z * fr * f;
                        a * fr * fr / (re * re + im * im).sqrt()
                    })
                    .sum::<f64>()
            })
            .collect()
    }

    fn root(f: f64, strength: f64) -> RootPeak {
        RootPeak {
            frequency_hz: f,
            damping_ratio: 0.005,
            strength,
            multiplicity: 1,
        }
    }

    #[test]
    fn a_split_pole_loses_its_peak_and_separate_peaks_both_stay() {
        // 1 Hz lines, lightly damped modes at 69 and 155 Hz.
        let freqs: Vec<f64> = (0..=300).map(|k| k as f64).collect();
        let c = curve(&freqs, &[(69.0, 0.005, 1.0), (155.0, 0.005, 0.5)]);
        let ev = PeakEvidence::new(&freqs, std::slice::from_ref(&c), 1e-12);
        assert_eq!(ev.peaks_hz, vec![69.0, 155.0]);
        // 69.0 (strong) and 69.7 (a split): the weaker loses to the stronger.
        let roots = [root(69.0, 10.0), root(69.7, 3.0), root(155.2, 5.0)];
        assert_eq!(ev.shared_peak_losers(&roots), vec![(1, 0)]);
        // The root nearest the peak keeps it, however broad the other;
        // on a tie the one carrying more of the fit.
        let roots = [root(69.0, 1.0), root(69.7, 3.0)];
        assert_eq!(ev.shared_peak_losers(&roots), vec![(1, 0)]);
        let roots = [root(68.98, 1.0), root(69.02, 3.0)];
        assert_eq!(ev.shared_peak_losers(&roots), vec![(0, 1)]);
        // Resolvable (2 lines apart) and alike: left to significance; much
        // broader: a loser however far.
        let roots = [root(69.0, 1.0), root(67.0, 3.0)];
        assert!(ev.shared_peak_losers(&roots).is_empty());
        let broad = RootPeak {
            damping_ratio: 0.03,
            ..root(67.0, 3.0)
        };
        assert_eq!(
            ev.shared_peak_losers(&[root(69.0, 1.0), broad]),
            vec![(1, 0)]
        );
        // Different peaks: never duplicates, nobody loses.
        assert!(ev.separate((69.0, 0.005), (155.0, 0.005)));
        assert!(!ev.separate((69.0, 0.005), (69.7, 0.005)));
        let roots = [root(69.0, 1.0), root(155.0, 1.0)];
        assert!(ev.shared_peak_losers(&roots).is_empty());
        // A root on no peak (a shoulder) keeps none and alone is not judged
        // here; with one reference (one curve), beside a stronger root
        // closer than 1.5 lines it is one feature of the data and loses;
        // 2 lines apart both stay for the significance test.
        let roots = [root(69.0, 5.0), root(110.0, 0.1), root(69.5, 1.0)];
        assert!(ev.shared_peak_losers(&roots[..2]).is_empty());
        assert_eq!(ev.keepers(&roots), vec![Some(0), None, Some(0)]);
        let roots = [root(110.0, 0.1), root(110.7, 0.4), root(69.0, 5.0)];
        assert_eq!(ev.keepers(&roots), vec![None, None, Some(2)]);
        assert_eq!(ev.shared_peak_losers(&roots), vec![(0, 1)]);
        let roots = [root(110.0, 0.1), root(112.0, 0.4)];
        assert!(ev.shared_peak_losers(&roots).is_empty());
        // With a second reference (a further curve, here flat) the pair off
        // the peaks is left to significance: participation can separate it.
        let ev2 = PeakEvidence::new(&freqs, &[c, vec![1e-3; freqs.len()]], 1e-12);
        let roots = [root(110.0, 0.1), root(110.7, 0.4)];
        assert!(ev2.shared_peak_losers(&roots).is_empty());
    }

    #[test]
    fn unresolved_pairs_are_closer_than_one_and_a_half_lines() {
        let f = [69.0, 69.7, 155.0, 157.0, 414.1, 414.9];
        assert_eq!(
            unresolved_pairs(1.0, &f),
            vec![(69.0, 69.7), (414.1, 414.9)]
        );
        assert!(unresolved_pairs(0.25, &f).is_empty());
    }

    #[test]
    fn a_second_cmif_curve_peak_lets_a_close_root_stay() {
        let freqs: Vec<f64> = (0..=300).map(|k| k as f64 * 0.5).collect();
        let first = curve(&freqs, &[(69.0, 0.005, 1.0)]);
        // The second singular value peaks at 69.5 Hz: a close second mode.
        let second = curve(&freqs, &[(69.5, 0.005, 0.3)]);
        let ev = PeakEvidence::new(&freqs, &[first.clone(), second], 1e-12);
        let roots = [root(69.0, 10.0), root(69.5, 3.0)];
        assert!(ev.shared_peak_losers(&roots).is_empty());
        // A flat second curve gives no such evidence.
        let ev = PeakEvidence::new(&freqs, &[first, vec![1e-3; freqs.len()]], 1e-12);
        assert_eq!(ev.shared_peak_losers(&roots), vec![(1, 0)]);
    }

    #[test]
    fn one_further_curve_peak_makes_room_for_one_more_root() {
        let freqs: Vec<f64> = (0..=300).map(|k| k as f64 * 0.5).collect();
        let first = curve(&freqs, &[(69.0, 0.005, 1.0)]);
        let second = curve(&freqs, &[(69.5, 0.005, 0.3)]);
        let ev = PeakEvidence::new(&freqs, &[first.clone(), second.clone()], 1e-12);
        assert_eq!(ev.further_curve_peaks(69.5, 0.005), 1);
        // Two roots beside the keeper: the stronger takes the one place.
        let roots = [root(69.0, 10.0), root(69.4, 2.0), root(69.6, 3.0)];
        assert_eq!(ev.shared_peak_losers(&roots), vec![(1, 0)]);
        let roots = [root(69.0, 10.0), root(69.4, 4.0), root(69.6, 3.0)];
        assert_eq!(ev.shared_peak_losers(&roots), vec![(2, 0)]);
        // A keeper that is a repeated root already holds that place.
        let double = RootPeak {
            multiplicity: 2,
            ..root(69.0, 10.0)
        };
        assert_eq!(
            ev.shared_peak_losers(&[double, root(69.5, 3.0)]),
            vec![(1, 0)]
        );
        // Two further curves peaking there: room for two.
        let third = curve(&freqs, &[(69.5, 0.005, 0.1)]);
        let ev = PeakEvidence::new(&freqs, &[first, second, third], 1e-12);
        let roots = [root(69.0, 10.0), root(69.4, 2.0), root(69.6, 3.0)];
        assert!(ev.shared_peak_losers(&roots).is_empty());
    }
}
