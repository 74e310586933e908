//! The state of one continuation run ([`super`]): the free parameters'
//! bounds, the prior about their start and the Huber weights of the
//! reference modes; one stage is Levenberg–Marquardt on the weighted
//! residuals of its mode set, refitted when its outliers change.

use super::super::history::Recorder;
use super::super::objective::{ModalObjective, ModeSet};
use super::super::IdentifyError;
use super::{ContinuationParams, Outlier};
use crate::optimize::levenberg_marquardt::{self, LmParams};
use crate::optimize::Bounds;
use rayon::prelude::*;

/// The state of one continuation run.
pub(super) struct Runner<'a> {
    o: &'a ModalObjective,
    free: &'a [usize],
    bounds: Bounds,
    /// The prior's centre (unit box of the free parameters).
    centre: Vec<f64>,
    settings: &'a ContinuationParams,
    /// σ̂ of the last stage, scaling the prior (module docs).
    prior_scale: f64,
    /// Per slot and reference mode: the factor on its residuals.
    weights: Vec<Vec<f64>>,
    recorder: &'a Recorder,
    progress: &'a (dyn Fn(u64) + Sync),
}

impl Runner<'_> {
    /// All parameter values: `base` with the free ones set to `values`.
    pub(super) fn point(&self, base: &[f64], values: &[f64]) -> Vec<f64> {
        let mut p = base.to_vec();
        for (j, &i) in self.free.iter().enumerate() {
            p[i] = values[j];
        }
        p
    }

    /// The weighted data residuals of `set` and the prior's, for a batch of
    /// free-parameter points around `base`; every point is recorded.
    fn residuals(&self, set: &ModeSet, base: &[f64], points: &[Vec<f64>]) -> Vec<Option<Vec<f64>>> {
        let v: Vec<_> = points
            .par_iter()
            .map(|p| self.o.evaluate(&self.point(base, p), set))
            .collect();
        let record: Vec<(f64, f64)> = v
            .iter()
            .map(|e| {
                e.as_ref()
                    .map_or((f64::INFINITY, 0.0), |e| (e.cost_usable, e.mean_mac))
            })
            .collect();
        self.recorder.record(&record);
        (self.progress)(points.len() as u64);
        let segments = self.o.segments(set);
        v.into_iter()
            .zip(points)
            .map(|(e, p)| {
                e.map(|e| {
                    let mut r = e.residuals;
                    let mut at = 0;
                    for &(slot, mode, len) in &segments {
                        let w = self.weights[slot][mode];
                        r[at..at + len].iter_mut().for_each(|v| *v *= w);
                        at += len;
                    }
                    r.extend(self.prior(p));
                    r
                })
            })
            .collect()
    }

    /// The prior's residuals at free-parameter values `p`.
    fn prior(&self, p: &[f64]) -> Vec<f64> {
        if self.settings.regularization <= 0.0 {
            return Vec::new();
        }
        self.bounds
            .to_unit(p)
            .iter()
            .zip(&self.centre)
            .map(|(a, b)| self.prior_scale * (a - b) / self.settings.regularization)
            .collect()
    }

    /// One stage: Levenberg–Marquardt on `set` from `x` (all values).
    fn stage(
        &self,
        set: &ModeSet,
        x: &[f64],
        budget: usize,
        last: bool,
    ) -> Result<levenberg_marquardt::LmResult, IdentifyError> {
        let params = LmParams {
            ftol: if last {
                LmParams::default().ftol
            } else {
                self.settings.stage_tolerance
            },
            max_step: self.settings.max_step,
            secant: self.settings.secant,
            ..LmParams::default()
        };
        let start: Vec<f64> = self.free.iter().map(|&i| x[i]).collect();
        let residuals = |points: &[Vec<f64>]| self.residuals(set, x, points);
        Ok(levenberg_marquardt::minimize(
            &self.bounds,
            &residuals,
            &start,
            budget,
            &params,
        )?)
    }

    /// σ̂ of a finished stage (its data cost over its residual count) as the
    /// next stage's prior scale.
    pub(super) fn update_prior_scale(&mut self, set: &ModeSet, r: &levenberg_marquardt::LmResult) {
        if self.settings.regularization <= 0.0 || !r.cost.is_finite() {
            return;
        }
        let prior: f64 = self.prior(&r.x_best).iter().map(|v| v * v).sum::<f64>() / 2.0;
        let m: usize = self
            .o
            .segments(set)
            .iter()
            .map(|s| s.2)
            .sum::<usize>()
            .max(1);
        let sigma = (2.0 * (r.cost - prior).max(0.0) / m as f64).sqrt();
        self.prior_scale = sigma.clamp(1e-6, 1.0);
    }

    /// Modes of `set` whose (unweighted) residual RMS at `x` exceeds
    /// `outlier` × the median (at least `outlier` σ); one evaluation.
    fn outliers(&self, set: &ModeSet, x: &[f64]) -> Vec<Outlier> {
        let limit = self.settings.outlier;
        if limit <= 0.0 {
            return Vec::new();
        }
        (self.progress)(1);
        let Some(e) = self.o.evaluate(x, set) else {
            return Vec::new();
        };
        let segments = self.o.segments(set);
        let mut at = 0;
        let rms: Vec<f64> = segments
            .iter()
            .map(|&(_, _, len)| {
                let v = &e.residuals[at..at + len];
                at += len;
                (v.iter().map(|v| v * v).sum::<f64>() / len as f64).sqrt()
            })
            .collect();
        let mut sorted = rms.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let bar = limit * median.max(1.0);
        segments
            .iter()
            .zip(&rms)
            .filter(|(_, &r)| r > bar)
            .map(|(&(slot, mode, _), &r)| Outlier {
                position: self.o.position(slot).index,
                mode: mode + 1,
                frequency_hz: self.o.reference_frequency(slot, mode),
                rms: r,
                median,
                weight: bar / r,
            })
            .collect()
    }
}

impl Runner<'_> {
    /// Set the weights of the modes of `set`: `found`'s to theirs, the
    /// rest to 1; true when the set of down-weighted modes changed.
    fn reweight(&mut self, set: &ModeSet, found: &[Outlier]) -> bool {
        let mut changed = false;
        for (slot, modes) in set.iter().enumerate() {
            for (mode, &inside) in modes.iter().enumerate() {
                if !inside {
                    continue;
                }
                let w = found
                    .iter()
                    .find(|f| self.o.slot(f.position) == Some(slot) && f.mode == mode + 1)
                    .map_or(1.0, |f| f.weight);
                changed |= (w < 1.0) != (self.weights[slot][mode] < 1.0);
                self.weights[slot][mode] = w;
            }
        }
        changed
    }
}

impl<'a> Runner<'a> {
    /// A run over `free` (indices), the prior centred on `prior` (all
    /// values), every mode at weight 1.
    pub(super) fn new(
        o: &'a ModalObjective,
        free: &'a [usize],
        prior: &[f64],
        settings: &'a ContinuationParams,
        recorder: &'a Recorder,
        progress: &'a (dyn Fn(u64) + Sync),
    ) -> Result<Self, IdentifyError> {
        let full = o.bounds()?;
        let bounds = full
            .select(free)
            .map_err(|e| IdentifyError::Invalid(e.to_string()))?;
        Ok(Runner {
            o,
            free,
            centre: bounds.to_unit(&free.iter().map(|&i| prior[i]).collect::<Vec<_>>()),
            bounds,
            settings,
            prior_scale: 1.0,
            weights: (0..o.positions())
                .map(|p| vec![1.0; o.modes_at(p)])
                .collect(),
            recorder,
            progress,
        })
    }

    /// One stage on `set` from `x` (all values) within `stage_budget`: the
    /// fit, its outliers, and the fit again when they change the weights.
    /// Returns the fit, the outliers at its end and the evaluations used.
    pub(super) fn fit_stage(
        &mut self,
        set: &ModeSet,
        x: &[f64],
        stage_budget: usize,
        last: bool,
    ) -> Result<(levenberg_marquardt::LmResult, Vec<Outlier>, usize), IdentifyError> {
        let n = self.free.len();
        let mut r = self.stage(set, x, stage_budget - 1, last)?;
        let mut used = r.evaluations;
        let found = self.outliers(set, &self.point(x, &r.x_best));
        used += 1;
        // Re-weight every mode of the stage from the residuals at its end
        // (iteratively reweighted Huber): a mode down-weighted while the
        // model was still far is restored once it fits, a new outlier is
        // down-weighted; when that changes the weights, fit the stage
        // again from its start.
        let redo = stage_budget.saturating_sub(r.evaluations + 1);
        if self.reweight(set, &found) && redo >= n + 2 {
            r = self.stage(set, x, redo, last)?;
            used += r.evaluations;
        }
        Ok((r, found, used))
    }
}
