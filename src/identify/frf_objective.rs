//! The measured FRFs as an identification reference: the residuals of the
//! model's FRFs against them, line by line, in units of each channel's noise
//! (FRF-based model updating; Friswell & Mottershead 1995, ch. 8; Lin &
//! Ewins 1994, "Analytical model improvement using frequency response
//! functions", MSSP 8(4), doi:10.1006/mssp.1994.1032).
//!
//! Why, when the modal objective exists: an EMA's modes are an incomplete
//! summary of the FRFs. A heavily damped mode (the test bench's axial drive
//! mode, ζ 0.11–0.19, 1–3 % from a lightly damped neighbour) is in the FRFs
//! but almost never in the AutoEMA modes (2 of 15 found over ten seeds), so
//! the modal objective cannot see the parameters that place it; the updated
//! model then has that mode anywhere, and its neighbours' shapes with it.
//! The FRFs hold every mode, however damped or close, with its residue.
//!
//! Per position, measured channel c (response j, reference k, matched to a
//! model sensor and excitation by node and axis; an opposite direction
//! flips the sign) and line ω inside the band:
//!
//! r_c(ω) = (H_jk^model(ω) − H_jk^meas(ω)) / σ_c,  real and imaginary parts,
//!
//! with H^model by modal superposition (eq. 2.42/2.45) of every model mode
//! below twice the band's top (the modes above it act as the residual
//! stiffness term in the band) in the measurement's quantity, and σ_c² the
//! channel's noise variance estimated from the data themselves
//! ([`crate::ema::noise::channel_noise_variance`]: fourth divided
//! differences, robust to the peaks). At the truth ½‖r‖²/count ≈ ½.
//!
//! **Noise of averaged estimates.** Fourth differences see only the noise
//! that changes from line to line. An impact test's H1 also carries noise
//! that is smooth across lines: force noise confined by the force window to
//! a few milliseconds has a smooth spectrum. On the test bench's simulated
//! hammer tests, two noise realizations of one truth differ with lag-1
//! correlation 0.7–0.97 and by 2–6× the fourth-difference σ. When the FRFs
//! carry coherence and the number of averages n is given
//! ([`FrfNoise::averages`]), each line's σ comes from the random error of a
//! frequency-response estimate (Bendat & Piersol, *Random Data*, 4th ed.,
//! eq. 9.73/9.90: gain and phase each (1 − γ²)/(2nγ²)):
//!
//! σ²(ω) = |H(ω)|² (1 − γ²(ω)) / (n γ²(ω)),
//!
//! never below the channel's fourth-difference σ.
//!
//! **Frequency drift.** A real test's natural frequencies are not the same
//! in every average: temperature and mass loading move them by 10⁻⁴–10⁻³
//! between averages and between tests. Where a mode is lightly damped, that
//! moves H far more than the channel noise does: at a resonance with
//! ζ = 0.06 % narrower than a line, a drift of 10⁻⁴ moves the line's value
//! by a sixth of the peak. Such a line is not known to better than
//! δ·s(ω), with s the FRF's sensitivity to the modes' relative frequencies
//! ([`superposition_with_drift`]), so each line's variance is
//! σ²(ω) = σ_c²(ω) + δ² s(ω)² (an effective variance, evaluated with the
//! model at the point being judged, so it sits where the model's peaks are).
//! At a peak of damping ζ it bounds the residual of a frequency error by
//! about ζ/δ standard deviations, so a one-line spike cannot dominate the fit
//! or point the score test at fixed parameters; at well-damped modes
//! (ζ ≫ δ) it changes nothing. Synthesized FRFs have no drift: δ = 0 makes
//! the noise the channel's alone.
//!
//! **Robust loss.** A line whose misfit exceeds [`HUBER`] σ counts linearly
//! (Huber): a lightly damped peak a hair off in frequency (ζ = 0.1 % is
//! 0.17 Hz wide at 84 Hz, narrower than a line), leakage of an impact test
//! at such a peak, or a local model error cannot dominate the thousands of
//! lines the fit is about.
//!
//! The stiffness parameters are not identified from the FRFs alone: the
//! FRF misfit is a landscape of narrow valleys far from the truth (a peak
//! 10 % off overlaps its measured twin nowhere). It refines a modal fit
//! that is already close ([`super::frf_refinement`]).

pub use super::local_misfit::{LocalMisfit, LOCAL_LINES};
use super::IdentifyError;
use crate::dynamics::frf::{superposition, superposition_with_drift};
use crate::dynamics::solve::{ModalSolution, ModeSelection};
use crate::dynamics::PreparedModel;
use crate::frf::{FrfQuantity, FrfSet};
use num_complex::Complex64;
pub use slot::coherence_sigma;
use slot::slot;
use std::f64::consts::TAU;

/// Per channel, one value per line.
type PerChannel<T> = Vec<Vec<T>>;

/// Misfit (σ units, per line and channel) above which a line counts
/// linearly.
pub const HUBER: f64 = 3.0;

/// The measured FRFs of one position, matched to the model's sensors and
/// excitations.
struct FrfSlot {
    /// Position index of the set.
    position: u32,
    config: usize,
    quantity: FrfQuantity,
    lines_hz: Vec<f64>,
    /// (model sensor row, model excitation row) per channel.
    pairs: Vec<(usize, usize)>,
    /// Sign of each channel (response sign × reference sign).
    signs: Vec<f64>,
    measured: Vec<Vec<Complex64>>,
    /// Noise standard deviation of each channel at each line.
    sigma: Vec<Vec<f64>>,
    /// Channels whose σ came from their coherence.
    from_coherence: usize,
    /// Channels with coherence but no `averages` to use it with.
    coherence_unused: usize,
    /// Modes below twice the top line at the model file's values: where
    /// the superposition's eigensolution starts looking
    /// ([`ModeSelection::BelowAbout`]); 14 (a first solve of 16) when
    /// that point cannot be solved.
    expected_modes: usize,
    /// Record length T = 1/Δf over which each mode's impulse response is
    /// cut (`FrfNoise::truncation`); `None`: the FRFs are not truncated.
    record_s: Option<f64>,
}

/// How the measured FRFs depart from the model's modal superposition: how
/// their noise is estimated, and how they were recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrfNoise {
    /// Averages n behind each FRF estimate: with coherence on a channel,
    /// σ² = |H|²(1 − γ²)/(nγ²) per line (module docs); `None`: fourth
    /// differences only.
    pub averages: Option<usize>,
    /// Relative standard deviation δ of every natural frequency between
    /// the averages of the test (module docs); 0: no drift term.
    pub drift: f64,
    /// `Some(t₀)`: the FRFs are impact-test estimates over a record of 1/Δf
    /// with no exponential window and the hit's centre t₀ seconds into it;
    /// the model's modes are then truncated alike
    /// ([`crate::dynamics::truncation`]).
    pub truncation: Option<f64>,
}

/// Windows' misfit powers and the model's natural frequencies at one point.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowProbe {
    /// Σ_c |d_c|² over each window's lines (noise units).
    pub powers: Vec<f64>,
    /// Undamped natural frequencies of the position's model, Hz, ascending.
    pub hz: Vec<f64>,
}

/// Measured FRFs prepared as a reference for a model.
pub struct FrfReference {
    slots: Vec<FrfSlot>,
    /// The highest line fitted, Hz; modes up to twice it enter the
    /// superposition (those above act as the residual stiffness).
    top_hz: f64,
    noise: FrfNoise,
}

/// The mode count and residue scale per slot that fix
/// [`FrfReference::modal_observables`] around one point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SuperpositionBasis {
    modes: Vec<usize>,
    residue_scale: Vec<f64>,
    /// Length of the observables vector.
    pub len: usize,
}

/// How well a model's FRFs fit the measured ones.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrfFit {
    /// RMS of the residuals in noise units (1: the fit is at the noise).
    pub rms: f64,
    /// The robust cost (Huber) over all residuals.
    pub robust_cost: f64,
    /// Mean FRAC over the channels (eq. 2.66).
    pub mean_frac: f64,
    /// Lag-1 autocorrelation of the residuals along frequency, pooled over
    /// channels and real/imaginary parts: ≈ 0 for noise, near 1 for a
    /// smooth, systematic misfit (damping model, leakage, model error).
    #[serde(default)]
    pub lag1: f64,
    /// The worst window of consecutive lines ([`LocalMisfit`]).
    #[serde(default)]
    pub local: Option<LocalMisfit>,
}

impl FrfReference {
    /// Match `sets` (by position index; only `positions` when given) to the
    /// model's sensor × excitation channels, keeping the lines inside
    /// `band_hz`. A position the model lacks, a set sharing no channel with
    /// it, or non-finite values are errors naming the position.
    pub fn new(
        model: &PreparedModel,
        sets: &[FrfSet],
        positions: Option<&[u32]>,
        band_hz: (f64, f64),
        noise: FrfNoise,
    ) -> Result<FrfReference, IdentifyError> {
        let mut slots = Vec::new();
        for set in sets {
            let index = set.position.index;
            if positions.is_some_and(|p| !p.contains(&index)) {
                continue;
            }
            slots.push(slot(model, set, band_hz, noise)?);
        }
        if slots.is_empty() {
            return Err(IdentifyError::Invalid(
                "the `frf` input has no position among the identified ones".into(),
            ));
        }
        let top = slots
            .iter()
            .filter_map(|s| s.lines_hz.last().copied())
            .fold(0.0, f64::max);
        let file_values: Vec<f64> = model.parameters.iter().map(|p| p.value).collect();
        for s in &mut slots {
            s.expected_modes = model
                .evaluate_modes(s.config, &file_values, ModeSelection::Below(2.0 * top))
                .map_or(14, |sol| sol.eigenvalues.len());
        }
        Ok(FrfReference {
            slots,
            top_hz: top,
            noise,
        })
    }

    /// What the noise of the residuals is, in words (cost.json, report).
    pub fn noise_model(&self) -> String {
        let channels: usize = self.slots.iter().map(|s| s.pairs.len()).sum();
        let coherent: usize = self.slots.iter().map(|s| s.from_coherence).sum();
        let channel = match self.noise.averages {
            Some(n) if coherent > 0 => format!(
                "coherence (n = {n}) on {coherent} of {channels} channels, fourth differences on the rest"
            ),
            _ => format!("fourth differences on {channels} channels"),
        };
        let mut text = channel;
        if self.noise.drift > 0.0 {
            text.push_str(&format!(
                ", with a frequency drift of {:e} (relative) at each line",
                self.noise.drift
            ));
        }
        // Every slot has its record length exactly when the truncation is on.
        if let Some(t0) = self.noise.truncation {
            let mut records: Vec<f64> = self.slots.iter().filter_map(|s| s.record_s).collect();
            records.sort_by(f64::total_cmp);
            records.dedup();
            let list: Vec<String> = records.iter().map(|t| format!("{t}")).collect();
            text.push_str(&format!(
                "; every mode cut at the end of an impact test's record of {} s (1/Δf, no exponential window), the hit's centre {t0} s into it",
                list.join(" / ")
            ));
        }
        text
    }

    /// A warning when the data carry coherence that could not be used
    /// because the number of averages was not given.
    pub fn noise_warning(&self) -> Option<String> {
        let unused: usize = self.slots.iter().map(|s| s.coherence_unused).sum();
        (unused > 0).then(|| {
            format!(
                "{unused} FRF channels carry coherence but `frf_averages` is not given: their noise comes from differences of neighbouring lines, which miss noise correlated across lines (force noise of impact tests), so the FRF residual may overstate the misfit; give frf_averages: <averages of the test>"
            )
        })
    }

    /// The modes slot `s`'s FRFs superpose: all up to twice the top line.
    fn superposed(&self, s: &FrfSlot) -> ModeSelection {
        ModeSelection::BelowAbout {
            hz: 2.0 * self.top_hz,
            expected: s.expected_modes,
        }
    }

    /// The highest line fitted, Hz.
    pub fn top_hz(&self) -> f64 {
        self.top_hz
    }

    /// First and last line of the [`LocalMisfit`] window centred on the
    /// line `centre_hz` of position `position`, Hz.
    pub fn window_hz(&self, position: u32, centre_hz: f64) -> Option<(f64, f64)> {
        let lines = &self.slots.iter().find(|s| s.position == position)?.lines_hz;
        let k = lines.partition_point(|&f| f < centre_hz);
        let half = super::local_misfit::LOCAL_LINES / 2;
        let last = lines.len().checked_sub(1)?;
        Some((
            lines[k.saturating_sub(half).min(last)],
            lines[(k + half).min(last)],
        ))
    }

    /// Σ_c |d_c|² over the lines `lo_hz..=hi_hz` of each of `windows` of
    /// position `position` at `x` (as [`LocalMisfit`] pools them) and the
    /// model's natural frequencies (Hz, ascending), from one eigensolution;
    /// `None` when it cannot be solved or the position is not fitted.
    pub fn window_probe(
        &self,
        model: &PreparedModel,
        x: &[f64],
        position: u32,
        windows: &[(f64, f64)],
    ) -> Option<WindowProbe> {
        let k = self.slots.iter().position(|s| s.position == position)?;
        let s = &self.slots[k];
        let sol = model.evaluate_modes(s.config, x, self.superposed(s)).ok()?;
        let misfits = self.misfits_of_slots(vec![self.frfs_of(s, &sol, &s.pairs)], &[k]);
        let d = || {
            misfits
                .iter()
                .flat_map(|(_, d, _)| d.iter().zip(&s.lines_hz))
        };
        let power = |(lo_hz, hi_hz): (f64, f64)| {
            let inside = d().filter(|(_, &f)| f >= lo_hz && f <= hi_hz);
            inside.map(|(v, _)| v.norm_sqr()).sum::<f64>()
        };
        let powers: Vec<f64> = windows.iter().map(|&w| power(w)).collect();
        let hz = sol.eigenvalues.iter().map(|w2| w2.max(0.0).sqrt() / TAU);
        let mut hz: Vec<f64> = hz.collect();
        hz.sort_by(f64::total_cmp);
        let finite = powers.iter().all(|p| p.is_finite());
        finite.then_some(WindowProbe { powers, hz })
    }

    /// The lines of position `position` from `lo_hz` to `hi_hz`, Hz.
    pub fn lines_between(&self, position: u32, (lo_hz, hi_hz): (f64, f64)) -> Vec<f64> {
        let slot = self.slots.iter().filter(|s| s.position == position).take(1);
        let lines = slot.flat_map(|s| s.lines_hz.iter().copied());
        lines.filter(|&f| f >= lo_hz && f <= hi_hz).collect()
    }

    /// Number of residuals (2 per channel and line).
    pub fn count(&self) -> usize {
        self.slots
            .iter()
            .map(|s| 2 * s.pairs.len() * s.lines_hz.len())
            .sum()
    }

    /// The modes behind the FRFs at `x`: per slot, how many modes its
    /// superposition holds and its largest residue, to fix the length and
    /// scale of [`Self::modal_observables`] around `x`.
    pub fn superposition_basis(
        &self,
        model: &PreparedModel,
        x: &[f64],
    ) -> Option<SuperpositionBasis> {
        let mut basis = SuperpositionBasis::default();
        for s in &self.slots {
            let sol = model.evaluate_modes(s.config, x, self.superposed(s)).ok()?;
            let largest = (0..sol.eigenvalues.len())
                .flat_map(|r| s.pairs.iter().map(move |&(j, k)| (r, j, k)))
                .map(|(r, j, k)| (sol.sensor_shapes[(j, r)] * sol.excitation_shapes[(k, r)]).abs())
                .fold(0.0, f64::max);
            basis.modes.push(sol.eigenvalues.len());
            basis
                .residue_scale
                .push(if largest > 0.0 { largest } else { 1.0 });
            basis.len += sol.eigenvalues.len() * (3 + s.pairs.len());
        }
        Some(basis)
    }

    /// What the model's FRFs at `x` are a function of: per slot and mode r
    /// of its superposition (eq. 2.42/2.45), the coefficients of the
    /// denominator ω_r² − ω² + j(2ζ_r ω ω_r + η_r ω_r²), i.e. ω_r², 2ζ_r ω_r
    /// and η_r ω_r² (over ω_top², ω_top: the top line's), and the residue
    /// φ_jr φ_kr of each channel (over the slot's largest at the basis
    /// point). A parameter direction that leaves these unchanged leaves
    /// every FRF unchanged, so the FRFs' structural null directions can be
    /// read from these smooth quantities, without the error of finite
    /// differences of the FRFs themselves at a sharp peak. `None` when the
    /// model cannot be solved or a slot's mode count differs from the
    /// basis's.
    pub fn modal_observables(
        &self,
        model: &PreparedModel,
        x: &[f64],
        basis: &SuperpositionBasis,
    ) -> Option<Vec<f64>> {
        let w_top = 2.0 * std::f64::consts::PI * self.top_hz;
        let mut out = Vec::new();
        for ((s, &n), &scale) in self
            .slots
            .iter()
            .zip(&basis.modes)
            .zip(&basis.residue_scale)
        {
            let sol = model
                .evaluate_modes(s.config, x, ModeSelection::Lowest(n))
                .ok()?;
            if sol.eigenvalues.len() != n {
                return None;
            }
            for r in 0..n {
                let l = sol.eigenvalues[r];
                out.push(l / (w_top * w_top));
                out.push(2.0 * sol.zeta[r] * l.sqrt() / w_top);
                out.push(sol.eta[r] * l / (w_top * w_top));
                out.extend(s.pairs.iter().map(|&(j, k)| {
                    sol.sensor_shapes[(j, r)] * sol.excitation_shapes[(k, r)] / scale
                }));
            }
        }
        Some(out)
    }

    /// Per position (slot), its lines and each channel's reference, in
    /// the order of [`Self::residuals`] (per channel its lines, two
    /// residuals, re and im, per line).
    pub fn layout(&self) -> Vec<super::batch_means::FrfLayout> {
        self.slots
            .iter()
            .map(|s| super::batch_means::FrfLayout {
                lines: s.lines_hz.len(),
                references: s.pairs.iter().map(|p| p.1).collect(),
            })
            .collect()
    }

    /// The model's FRFs at `x` for slot `s` ([`Self::frfs_of`]).
    fn model_frfs(
        &self,
        model: &PreparedModel,
        s: &FrfSlot,
        x: &[f64],
    ) -> Option<(PerChannel<Complex64>, Option<PerChannel<f64>>)> {
        let sol = model.evaluate_modes(s.config, x, self.superposed(s)).ok()?;
        Some(self.frfs_of(s, &sol, &s.pairs))
    }

    /// How long after the hit slot `s`'s record ends (T − t₀), when its
    /// FRFs are truncated.
    fn cut_after(&self, s: &FrfSlot) -> Option<f64> {
        Some(s.record_s? - self.noise.truncation?)
    }

    /// Slot `s`'s FRFs superposed from `sol` with the rows `pairs` (one per
    /// channel), signed as measured, and with δ > 0 each line's noise σ:
    /// the channel's with the drift term δ² s(ω)² of `sol` added (module
    /// docs); `None`: the channel's σ as it is.
    fn frfs_of(
        &self,
        s: &FrfSlot,
        sol: &ModalSolution,
        pairs: &[(usize, usize)],
    ) -> (PerChannel<Complex64>, Option<PerChannel<f64>>) {
        let drift = self.noise.drift;
        let (mut h, sigma) = if drift > 0.0 {
            let (h, spread) =
                superposition_with_drift(sol, s.quantity, &s.lines_hz, pairs, self.cut_after(s));
            let sigma = s
                .sigma
                .iter()
                .zip(&spread)
                .map(|(sc, sd)| sc.iter().zip(sd).map(|(c, d)| c.hypot(drift * d)).collect())
                .collect();
            (h, Some(sigma))
        } else {
            (
                superposition(sol, s.quantity, &s.lines_hz, pairs, self.cut_after(s)),
                None,
            )
        };
        for (v, &sign) in h.iter_mut().zip(&s.signs) {
            v.iter_mut().for_each(|z| *z *= sign);
        }
        (h, sigma)
    }

    /// Per slot and channel, the noise-scaled misfit d = (H^model −
    /// H^meas)·√2/σ_c at every line (σ_c² = E|n|² is split evenly between
    /// the real and imaginary parts, so each part of d has unit variance),
    /// with the slot's index and the channel's FRAC.
    fn misfits(
        &self,
        model: &PreparedModel,
        x: &[f64],
    ) -> Option<Vec<(usize, Vec<Complex64>, f64)>> {
        let frfs = self
            .slots
            .iter()
            .map(|s| self.model_frfs(model, s, x))
            .collect::<Option<Vec<_>>>()?;
        Some(self.misfits_of(frfs))
    }

    /// [`Self::misfits`] of the model FRFs `frfs` (per slot, as from
    /// [`Self::frfs_of`]).
    fn misfits_of(
        &self,
        frfs: Vec<(PerChannel<Complex64>, Option<PerChannel<f64>>)>,
    ) -> Vec<(usize, Vec<Complex64>, f64)> {
        let all: Vec<usize> = (0..self.slots.len()).collect();
        self.misfits_of_slots(frfs, &all)
    }

    /// [`Self::misfits_of`] for the slots `ks` only, `frfs[i]` of slot `ks[i]`.
    fn misfits_of_slots(
        &self,
        frfs: Vec<(PerChannel<Complex64>, Option<PerChannel<f64>>)>,
        ks: &[usize],
    ) -> Vec<(usize, Vec<Complex64>, f64)> {
        let mut out = Vec::new();
        for (&k, (h, drifting)) in ks.iter().zip(frfs) {
            let s = &self.slots[k];
            let sigmas = drifting.as_ref().unwrap_or(&s.sigma);
            for ((m, meas), sigma) in h.iter().zip(&s.measured).zip(sigmas) {
                let d: Vec<Complex64> = m
                    .iter()
                    .zip(meas)
                    .zip(sigma)
                    .map(|((p, q), s)| (p - q) * (std::f64::consts::SQRT_2 / s))
                    .collect();
                out.push((k, d, crate::metrics::frac(meas, m)));
            }
        }
        out
    }

    /// The noise-scaled residuals at `x`, Huber-transformed per line and
    /// channel (½‖r‖² is the robust cost), or `None` when the model cannot
    /// be solved there.
    pub fn residuals(&self, model: &PreparedModel, x: &[f64]) -> Option<Vec<f64>> {
        self.robust(self.misfits(model, x)?)
    }

    /// The Huber-transformed residuals of `misfits`; `None` when one is
    /// not finite.
    fn robust(&self, misfits: Vec<(usize, Vec<Complex64>, f64)>) -> Option<Vec<f64>> {
        let mut out = Vec::with_capacity(self.count());
        for (_, d, _) in misfits {
            for v in d {
                let w = huber_factor(v.norm());
                out.extend([w * v.re, w * v.im]);
            }
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The fit at `x`: noise-unit RMS, robust cost, mean FRAC and the
    /// worst local misfit ([`LocalMisfit`]).
    pub fn fit(&self, model: &PreparedModel, x: &[f64]) -> Option<FrfFit> {
        let (mut sum2, mut count, mut robust) = (0.0, 0usize, 0.0);
        let (mut frac, mut channels, mut lagged) = (0.0, 0usize, 0.0);
        // Per slot and line, Σ_c |d_c|² and the channel count.
        let mut power: Vec<(Vec<f64>, usize)> = self
            .slots
            .iter()
            .map(|s| (vec![0.0; s.lines_hz.len()], 0))
            .collect();
        for (k, d, f) in self.misfits(model, x)? {
            for (l, v) in d.iter().enumerate() {
                let n = v.norm();
                sum2 += n * n;
                count += 2;
                let w = huber_factor(n);
                robust += 0.5 * w * w * n * n;
                if let Some(p) = power[k].0.get_mut(l) {
                    *p += n * n;
                }
            }
            power[k].1 += 1;
            lagged += d
                .windows(2)
                .map(|w| w[0].re * w[1].re + w[0].im * w[1].im)
                .sum::<f64>();
            frac += f;
            channels += 1;
        }
        let rms = (sum2 / count.max(1) as f64).sqrt();
        let local = self
            .slots
            .iter()
            .zip(&power)
            .filter_map(|(s, (p, n))| LocalMisfit::worst(s.position, &s.lines_hz, p, *n))
            .max_by(|a, b| a.rms.total_cmp(&b.rms));
        rms.is_finite().then_some(FrfFit {
            rms,
            robust_cost: robust,
            mean_frac: frac / channels.max(1) as f64,
            lag1: lagged / sum2.max(f64::MIN_POSITIVE),
            local,
        })
    }
}

/// The factor w with ½(w·d)² = Huber(d): 1 up to [`HUBER`], then
/// √(2c/d − c²/d²) so that ½w²d² = c·d − ½c².
fn huber_factor(d: f64) -> f64 {
    if d <= HUBER {
        1.0
    } else {
        (2.0 * HUBER / d - HUBER * HUBER / (d * d)).sqrt()
    }
}

mod sensitivity;
mod slot;
#[cfg(test)]
mod tests;
