//! The `autoema` kind: automated experimental modal analysis of an `frf`
//! artifact (seed section 5.2.2, PUB5) with [`crate::ema`]: PolyMAX poles up
//! to the highest order, roots validated against the noise floor (duplicates,
//! significance, repeated roots), selection hyperparameters tuned by
//! Bayesian optimization on the mean FRAC of the validated modes over a box
//! fitted to the data, mode shapes by LSFD. Every position of the input is
//! analysed on its own (in parallel; results do not depend on the thread
//! count). metrics.json states per position what was rejected and why, any
//! hyperparameter at a bound, residual structure above the noise and whether
//! the goal was reached.

use super::{Artifact, InputSpec, Kind, ParamProblem, StageContext, StageError, StageOutputs};
use crate::artifacts;
use crate::ema::summary::PositionSummary;
use crate::ema::{auto_ema, layout, AutoEmaResult, FrfData, Layout};
use crate::frf::{FrfChannel, FrfSet};
use crate::modal::{ModalModel, Mode};
use crate::report::stabilization::{render, Panel};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write;

mod params;

use params::{check, settings};
pub use params::{MaxOrder, NoiseParam, Params, ReciprocityParam, WeightingParam};

pub struct AutoEma;

const INPUTS: &[InputSpec] = &[InputSpec {
    name: "frf",
    required: true,
    list: false,
    artifact: Artifact::Frf,
    doc: "FRFs (an `frf` artifact): responses × references, any ratio; partial matrices by the `reciprocity` rule",
}];

impl Kind for AutoEma {
    type Params = Params;
    const NAME: &'static str = "autoema";

    /// 5: modes.csv always has the position columns (issue 31);
    /// frf_fit keeps the input's uncalibrated mark.
    /// 6: no missing-mode warning at an identified mode; coherence widens
    /// the residual check's noise; a bound warns only when the objective
    /// beyond it is better (issue 31).
    /// 7: uncertainty.csv says `frequency_std_rel,damping_std_rel`, poles.csv's
    /// flags are `true`/`false` (issue 28).
    /// 8: a pole refined on the FRFs stays inside its stable column's
    /// frequency range (the tool holder's 1330 Hz column had walked to
    /// 1231 Hz over the sweeps); a lightly damped root kept for significance
    /// alone on a short stable column is dropped (`short_column`: split and
    /// mixed poles of the UFSC shaker test) (issue 31).
    /// 9: the positions' warnings (metrics.json `warnings`) are the stage's
    /// warnings too — `warning:` lines, the run's count, reports — cached or
    /// not; the outputs are unchanged (issue 29).
    /// 10: every stable column (≥ 5 orders) ends as a root or in
    /// `rejected` — the clustering's dropped columns are recorded as
    /// `sparse_column` or `wide_column` (the vibration-toolbox case 1's
    /// 162 Hz column vanished without trace); metrics.json `data` reports
    /// `frf_peaks` (the FRFs' own peaks with ≤ 2 references) beside
    /// `cmif_peaks`; the modes are unchanged (issue 31).
    /// (11, reverted: a stable column allowed to scatter by a quarter of
    /// its damping ratio admitted 6 spurious heavily damped modes on the
    /// vertical mill family's first position; the algorithm is 10's again, so is the key.)
    /// 12: each further CMIF curve peak at a first-curve peak makes room for
    /// one unresolved root beside its keeper, no more (the UFSC beam's two
    /// tests combined kept four roots at 567 Hz, three at 741 Hz); the
    /// missing-mode warnings are one per stretch between identified modes
    /// (vibration-toolbox case 1: 9 → 3) (issue 31).
    /// 13: a short stable column is kept when the fit without it leaves a
    /// data peak near it ≥ 10× above the noise that the fit with it
    /// explains (`accepted_by: data_peak`): the vertical mill's impact tests lost one of a 0.5 %
    /// close pair at 174 Hz (ζ 0.1 %) this way and then warned that a mode
    /// is missing there (issues 26, 31).
    /// 14: noise that varies along the band by more than √10 in standard
    /// deviation is whitened (`ema::whitening`): every fit and test weights
    /// the lines by it (issue 31: a receptance over 100–8900 Hz).
    /// 15: the multiplicity test scales the residue matrix separably, so a
    /// simple mode's rank-1 residue stays rank 1: channels of unequal noise
    /// had made strong modes "repeated roots" (the `wide_band` family, noise
    /// ∝ |H|: 44 → 13 duplicates over 80 cases; close pair at 5 %: 17 → 19/20).
    /// 16: with one reference, a root on no CMIF peak closer than 1.5 lines
    /// to a stronger root must earn its place as on a shared peak
    /// (`ema::peak_evidence`; the UFSC shaker test's 274.2/274.9 Hz pair at
    /// 1 Hz lines).
    /// 17: the pole refinement's normal equations by one blocked product
    /// (`dense::normal_equations`); results may differ from 16 in rounding
    /// (the quickstart's modes are byte-identical).
    /// 18: a fit whose FRAC the noise does not explain is warned about
    /// (`ema::adequacy`); each mode reports its half-power band in lines.
    /// The modes are those of 17.
    /// 19: a bound beyond which the selection is better but holds the same
    /// modes is listed in `at_bound`, not warned about.
    /// 20: the modes a better selection beyond a bound lacks are named in
    /// one warning per position.
    /// 21: a mode none of the 12 next-best selections holds is dropped
    /// (`no_consensus`); every mode reports its `support`.
    /// 22: a mode kept for significance alone whose score is below the
    /// inflation of its ΔRSS by the residual's serial correlation, held by
    /// fewer than half of the next-best selections, is dropped
    /// (`serial_correlation`, `ema::serial_correlation`); every mode
    /// reports its `serial_inflation` (issue 31: the tool holder's driving
    /// point 8 → 3 extras).
    fn version(&self) -> u32 {
        22
    }
    fn summary(&self) -> &'static str {
        "automated modal analysis: PolyMAX, stabilization, clustering, roots validated against the noise, LSFD, tuned by Bayesian optimization"
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("modes", Artifact::Modes),
        ("poles", Artifact::Table),
        ("frf_fit", Artifact::Frf),
        ("stabilization", Artifact::Figure),
        ("metrics", Artifact::Json),
    ];
    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        check(p)
    }
    fn uses_seed(&self) -> bool {
        false
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let s = settings(p);
        // Uncalibrated FRFs (no physical scale) are fine for AutoEMA; the
        // fitted FRFs carry the same mark.
        let (sets, calibrated) = artifacts::frf::read_scaled(ctx.input("frf")?, "frf")?;
        // Lines at 0 Hz are dropped: the LSFD lower residual −LR/ω² is singular there.
        let band = s
            .band
            .map_or((f64::MIN_POSITIVE, f64::INFINITY), |(lo, hi)| {
                (lo.max(f64::MIN_POSITIVE), hi)
            });
        let (data, layouts): (Vec<FrfData>, Vec<Layout>) = sets
            .iter()
            .map(|set| layout::frf_data(set, Some(band), s.weighting, s.reciprocity))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| StageError::InvalidInput {
                input: "frf".into(),
                message: e.to_string(),
            })?
            .into_iter()
            .unzip();
        ctx.progress
            .set_length((s.ema.evaluations * sets.len()) as u64);
        let tick = || ctx.progress.inc(1);
        let results: Vec<AutoEmaResult> = data
            .par_iter()
            .zip(&sets)
            .map(|(d, set)| {
                auto_ema(d, &s.ema, &tick).map_err(|e| {
                    StageError::Failed(format!(
                        "position {} ({}): {e}",
                        set.position.index, set.position.label
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        write_outputs(ctx, (&sets, calibrated), &data, &layouts, &results)
    }
}

/// The metrics.json of the stage.
#[derive(serde::Serialize)]
struct Metrics {
    /// How references and responses were fitted
    /// ([`crate::ema::layout`]): the positions' common description, or
    /// each one's prefixed with its position.
    layout: String,
    /// Every position reached its goal (no visible mode missed, no result
    /// limited by the search box).
    goal_reached: bool,
    mean_frac: f64,
    n_modes: usize,
    /// The positions' warnings, each prefixed with its position.
    warnings: Vec<String>,
    positions: Vec<PositionSummary>,
}

fn modal_models(sets: &[FrfSet], data: &[FrfData], results: &[AutoEmaResult]) -> Vec<ModalModel> {
    sets.iter()
        .zip(data)
        .zip(results)
        .map(|((set, d), r)| ModalModel {
            position: set.position.clone(),
            dofs: d.responses.clone(),
            modes: r
                .fit
                .shapes
                .iter()
                .zip(&r.fit.shape_pole)
                .map(|(shape, &k)| {
                    let p = r.best.roots[k].pole(&r.orders);
                    Mode {
                        frequency_hz: p.frequency_hz,
                        damping_ratio: p.damping_ratio,
                        shape: shape.clone(),
                    }
                })
                .collect(),
        })
        .collect()
}

/// Per written mode (same order as [`modal_models`]) its root's stable
/// column spread ([`crate::ema::roots::Root::spread`]): the estimate's own
/// statement of how well it knows the mode, which `identify` turns into
/// residual weights.
fn mode_spread(sets: &[FrfSet], results: &[AutoEmaResult]) -> Vec<artifacts::modes::ModeSpread> {
    sets.iter()
        .zip(results)
        .flat_map(|(set, r)| {
            r.fit.shape_pole.iter().enumerate().map(move |(m, &k)| {
                let (frequency, damping) = r.best.roots[k].spread(&r.orders);
                artifacts::modes::ModeSpread {
                    position: set.position.index,
                    mode: m + 1,
                    frequency,
                    damping,
                }
            })
        })
        .collect()
}

/// poles.csv: every pole with its stabilization flags and class, its
/// cluster and root, and whether it represents a mode (booleans
/// `true`/`false`, as in every artifact).
fn poles_csv(sets: &[FrfSet], results: &[AutoEmaResult]) -> String {
    let mut out = String::from("position,order,frequency_hz,damping_ratio,physical,stable_frequency,stable_damping,stable_vector,class,cluster,root,selected\n");
    for (set, r) in sets.iter().zip(results) {
        let mut cluster_of: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for (k, c) in r.best.clusters.iter().enumerate() {
            for &m in &c.members {
                cluster_of.insert(m, k);
            }
        }
        let mut root_of: BTreeMap<(usize, usize), (usize, bool)> = BTreeMap::new();
        for (k, root) in r.best.roots.iter().enumerate() {
            for &m in &root.members {
                root_of.insert(m, (k, m == root.representative));
            }
        }
        for (j, order) in r.orders.iter().enumerate() {
            for (k, p) in order.poles.iter().enumerate() {
                let fl = r
                    .best
                    .flags
                    .get(j)
                    .and_then(|f| f.get(k))
                    .copied()
                    .unwrap_or_default();
                let cluster = cluster_of
                    .get(&(j, k))
                    .map_or(String::new(), ToString::to_string);
                let (root, selected) = root_of
                    .get(&(j, k))
                    .map_or((String::new(), false), |&(c, s)| (c.to_string(), s));
                let b = |v: bool| v;
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{},{},{},{}",
                    set.position.index,
                    order.order,
                    p.frequency_hz,
                    p.damping_ratio,
                    b(fl.physical),
                    b(fl.stable_frequency),
                    b(fl.stable_damping),
                    b(fl.stable_vector),
                    fl.class().code(),
                    cluster,
                    root,
                    b(selected)
                );
            }
        }
    }
    out
}

/// The fitted FRFs, with responses and references as measured (a
/// transposed fit's output o, reference i is the measured response i,
/// reference o).
fn fitted_sets(
    sets: &[FrfSet],
    data: &[FrfData],
    layouts: &[Layout],
    results: &[AutoEmaResult],
) -> Vec<FrfSet> {
    sets.iter()
        .zip(data)
        .zip(layouts)
        .zip(results)
        .map(|(((set, d), l), r)| {
            let nf = d.n_lines();
            let mut channels = Vec::new();
            for (o, &out) in d.responses.iter().enumerate() {
                for (i, &input) in d.references.iter().enumerate() {
                    let c = o * d.n_ref() + i;
                    let (response, reference) = if l.transposed {
                        (input, out)
                    } else {
                        (out, input)
                    };
                    channels.push(FrfChannel {
                        response,
                        reference,
                        values: r.fit.reconstructed[c * nf..(c + 1) * nf].to_vec(),
                        coherence: None,
                    });
                }
            }
            FrfSet {
                position: set.position.clone(),
                quantity: set.quantity,
                frequencies_hz: d.frequencies_hz.clone(),
                channels,
            }
        })
        .collect()
}

fn metrics(
    sets: &[FrfSet],
    data: &[FrfData],
    layouts: &[Layout],
    results: &[AutoEmaResult],
) -> Metrics {
    let positions: Vec<PositionSummary> = sets
        .iter()
        .zip(data)
        .zip(layouts)
        .zip(results)
        .map(|(((set, d), l), r)| {
            PositionSummary::of(
                set.position.index,
                &set.position.label,
                &d.h,
                d.n_lines(),
                l,
                r,
            )
        })
        .collect();
    Metrics {
        layout: layout::describe(&positions_of(sets, layouts)),
        goal_reached: positions.iter().all(|p| p.goal_reached),
        mean_frac: positions.iter().map(|p| p.mean_frac).sum::<f64>()
            / positions.len().max(1) as f64,
        n_modes: positions.iter().map(|p| p.n_modes).sum(),
        warnings: positions
            .iter()
            .flat_map(|p| {
                p.warnings
                    .iter()
                    .map(move |w| format!("position {} ({}): {w}", p.index, p.label))
            })
            .collect(),
        positions,
    }
}

/// Each position's index with its layout.
fn positions_of<'a>(sets: &[FrfSet], layouts: &'a [Layout]) -> Vec<(u32, &'a Layout)> {
    sets.iter().map(|s| s.position.index).zip(layouts).collect()
}

fn write_outputs(
    ctx: &StageContext,
    (sets, calibrated): (&[FrfSet], bool),
    data: &[FrfData],
    layouts: &[Layout],
    results: &[AutoEmaResult],
) -> Result<StageOutputs, StageError> {
    let modes_dir = ctx.scratch.join(artifacts::modes::DIR);
    artifacts::modes::write_modes(&modes_dir, &modal_models(sets, data, results))?;
    artifacts::modes::write_mode_spread(&modes_dir, &mode_spread(sets, results))?;
    write(
        &modes_dir.join("layout.json"),
        &serde_json::to_vec_pretty(&layout::to_json(&positions_of(sets, layouts)))
            .map_err(|e| StageError::Failed(e.to_string()))?,
    )?;
    let poles_path = ctx.scratch.join("poles.csv");
    write(&poles_path, poles_csv(sets, results).as_bytes())?;
    let fit_path = ctx.scratch.join("frf_fit.uff");
    let fitted = fitted_sets(sets, data, layouts, results);
    artifacts::frf::write_scaled(&fit_path, &fitted, calibrated)?;
    let panels: Vec<Panel> = sets
        .iter()
        .zip(data)
        .zip(results)
        .map(|((set, d), r)| Panel {
            title: format!(
                "Stabilization diagram, position {} {}",
                set.position.index, set.position.label
            ),
            data: d,
            result: r,
        })
        .collect();
    let svg_path = ctx.scratch.join("stabilization.svg");
    write(&svg_path, render(&panels).as_bytes())?;
    let m = metrics(sets, data, layouts, results);
    let metrics_path = ctx.scratch.join("metrics.json");
    write(
        &metrics_path,
        &serde_json::to_vec_pretty(&m).map_err(|e| StageError::Failed(e.to_string()))?,
    )?;
    let iterations: usize = results.iter().map(|r| r.trace.len()).sum();
    let orders: usize = results.iter().map(|r| r.orders.len()).sum();
    Ok(StageOutputs {
        warnings: m.warnings,
        files: vec![
            ("modes".into(), modes_dir),
            ("poles".into(), poles_path),
            ("frf_fit".into(), fit_path),
            ("stabilization".into(), svg_path),
            ("metrics".into(), metrics_path),
        ],
        counters: [
            ("bo_iterations".to_string(), iterations as u64),
            ("orders".to_string(), orders as u64),
            (
                "transposed_positions".to_string(),
                layouts.iter().filter(|l| l.transposed).count() as u64,
            ),
        ]
        .into(),
    })
}

fn write(path: &std::path::Path, bytes: &[u8]) -> Result<(), StageError> {
    std::fs::write(path, bytes)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

#[cfg(test)]
#[path = "autoema_tests.rs"]
mod tests;
