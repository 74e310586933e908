//! AutoEMA benchmarks (issue 14), three parts, each a separate argument:
//!
//! - `polymax` (default): PolyMAX for every order up to 60 on 30 outputs ×
//!   3 references × 1601 lines, normal equations built once and reused
//!   across orders against the per-order rebuild, in the same run; then the
//!   cost of one Bayesian-optimization step (re-selection from the poles).
//! - `families [seeds] [noise…] [white|profile] [family…]`: the synthetic
//!   families of `modalflow::ema::families` (close pair 1 % apart, repeated
//!   root with 3 references, damping 5–8 %, 600 FRFs × 2001 lines with 20
//!   modes, modes beyond the band edges, noise ∝ |H| over a wide band) over
//!   many seeds and noise levels with default settings: success rate (every
//!   visible mode found with NFD < 0.5 %, NDD < 20 %, MAC ≥ 0.9; no spurious
//!   or duplicate mode; mean FRAC ≥ 1/(1 + r²) − 0.001), spurious and
//!   duplicate counts, median NFD/NDD/MAC, CPU seconds per case. `white`
//!   or `profile` sets the `noise` model (default `auto`, as the stage).
//! - `scale`: one PUB5-size position (the `large` family) with the time of
//!   each phase: PolyMAX, the search, the final steps.
//!
//! - `real [LO HI [ITERATIONS [FILES]]]`: the real beam of
//!   `../shared/data/real/beam_ufsc_ss` (hammer as measured, shaker, MIMO;
//!   FILES comma-separated) on the band [LO, HI] Hz (default 5–800) with
//!   every variant 0–7 of the Sobol design (`AutoEmaParams::design`): the
//!   modes, evaluations, chosen order and CPU seconds per variant, i.e. how
//!   much a result owes to the search design (the stage always uses 0).
//!
//! - `export DIR FAMILY SEED NOISE [POSITIONS]`: one family member for
//!   `benchmarks/autoema_compare.py` — `frf.uff` (58b, POSITIONS copies with
//!   independent noise, for the PUB5-size run of 4 positions), `frf.bin`
//!   (little-endian f64 re/im, channels × lines, position 0) and
//!   `case.json` (lines, references, outputs, true modes).
//!
//! `cargo bench --bench polymax -- families 20 0.02 0.05`
//! (`RAYON_NUM_THREADS=1` for CPU time per case).

mod timing;

use modalflow::ema::families::{case, estimates, frf_data, frf_set, score, Score, FAMILIES};
use modalflow::ema::synthetic::{lines, modal_superposition, SyntheticMode};
use modalflow::ema::whitening::NoiseModel;
use modalflow::ema::{
    auto_ema, polymax, polymax_rebuild_per_order, select_modes, AutoEmaParams, FrfData,
    Hyperparameters, PolymaxParams, Screening, SelectionParams, Weighting,
};
use timing::best;

/// [`best`] in milliseconds.
fn best_ms<T>(n: usize, f: impl FnMut() -> T) -> (f64, T) {
    let (s, out) = best(n, f);
    (s * 1e3, out)
}

fn system() -> Vec<SyntheticMode> {
    (0..12)
        .map(|r| SyntheticMode {
            frequency_hz: 60.0 + 57.0 * r as f64 + 3.0 * (r * r) as f64,
            damping_ratio: 0.01 + 0.001 * r as f64,
            shape: (0..30)
                .map(|j| {
                    ((r + 1) as f64 * (j as f64 + 0.5) * std::f64::consts::PI / 31.0).sin()
                        + 0.05 * ((r * j) % 7) as f64
                })
                .collect(),
        })
        .collect()
}

fn polymax_reuse() {
    let set = modal_superposition(&system(), &[0, 11, 22], &lines(10.0, 810.0, 0.5), 0.01, 1);
    let data = FrfData::from_set(&set, None, Weighting::Uniform).expect("synthetic data");
    let params = PolymaxParams { max_order: 60 };
    println!(
        "PolyMAX, orders 1..=60, {} outputs × {} references × {} lines, {} threads",
        data.n_out(),
        data.n_ref(),
        data.n_lines(),
        rayon::current_num_threads()
    );
    let (t_fast, orders) = best_ms(3, || polymax(&data, &params).expect("polymax"));
    let (t_ref, reference) = best_ms(1, || {
        polymax_rebuild_per_order(&data, &params).expect("reference")
    });
    let max_dev = orders
        .iter()
        .zip(&reference)
        .flat_map(|(a, b)| {
            a.poles
                .iter()
                .zip(&b.poles)
                .map(|(p, q)| (p.s - q.s).norm() / p.s.norm())
        })
        .fold(0.0, f64::max);
    println!("{:<44} {:>10}", "variant", "ms");
    println!(
        "{:<44} {:>10.1}",
        "normal equations reused across orders", t_fast
    );
    println!("{:<44} {:>10.1}", "reference: rebuilt per order", t_ref);
    println!(
        "speed-up {:.1}×, largest relative pole difference {:.1e}",
        t_ref / t_fast,
        max_dev
    );
    let h = Hyperparameters {
        frequency_tol: 0.01,
        damping_tol: 0.1,
        mac_tol: 0.02,
        max_damping: 0.1,
        cluster_distance: 0.01,
        min_cluster_fraction: 0.3,
        damping_weight: 0.5,
        mac_weight: 0.5,
        max_order: 60,
    };
    let mut screening = Screening::new(&data, SelectionParams::default());
    let (t_first, sel) = best_ms(1, || select_modes(&mut screening, &orders, &h));
    let (t_step, _) = best_ms(10, || select_modes(&mut screening, &orders, &h));
    println!(
        "one BO step (stabilize, cluster, roots, validate, FRAC): first {:.2} ms (projections of new poles), then {:.2} ms; {} modes, mean FRAC {:.5}",
        t_first,
        t_step,
        sel.n_modes(),
        sel.mean_frac
    );
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One family at one noise level over `seeds` seeds, its noise taken as
/// `model` says.
fn family(name: &str, noise: f64, seeds: u64, model: NoiseModel) {
    let (mut ok, mut spurious, mut duplicate, mut missed, mut secs) = (0, 0, 0, 0, 0.0);
    let (mut nfd, mut ndd, mut mac) = (Vec::new(), Vec::new(), Vec::new());
    let mut failures = Vec::new();
    for seed in 1..=seeds {
        let Some(c) = case(name, seed) else { return };
        let d = frf_data(&c, noise, seed);
        let t = cpu_seconds();
        let p = AutoEmaParams {
            noise: model,
            ..AutoEmaParams::default()
        };
        let r = match auto_ema(&d, &p, &|| {}) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("seed {seed}: {e}"));
                continue;
            }
        };
        secs += cpu_seconds() - t;
        let s: Score = score(&c, noise, &estimates(&r), r.best.mean_frac);
        ok += usize::from(s.success);
        spurious += s.spurious;
        duplicate += s.duplicate;
        missed += s.visible - s.found;
        if !s.success {
            failures.push(format!(
                "seed {seed}: found {}/{}, spurious {}, duplicate {}, FRAC {:.5}",
                s.found, s.visible, s.spurious, s.duplicate, r.best.mean_frac
            ));
        }
        nfd.extend(s.nfd);
        ndd.extend(s.ndd);
        mac.extend(s.mac);
    }
    println!(
        "{name:<14} {noise:>5.2} {:>6}/{:<3} {missed:>7} {spurious:>9} {duplicate:>9} {:>10.2e} {:>9.3} {:>8.4} {:>9.2}",
        ok,
        seeds,
        median(nfd),
        median(ndd),
        median(mac),
        secs / seeds as f64
    );
    for f in failures {
        println!("    {f}");
    }
}

/// CPU time of this process (user + system), for the shared 2-core machine.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let tick = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (tick(11) + tick(12)) / 100.0
}

fn families(args: &[String]) {
    let seeds: u64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(20);
    let noises: Vec<f64> = args.iter().skip(1).filter_map(|s| s.parse().ok()).collect();
    // `white` or `profile` overrides the stage's default `auto`; family
    // names select families (default: all).
    let has = |word: &str| args.iter().any(|a| a == word);
    let model = if has("white") {
        NoiseModel::White
    } else if has("profile") {
        NoiseModel::Profile
    } else {
        NoiseModel::Auto
    };
    let chosen: Vec<&str> = FAMILIES.into_iter().filter(|f| has(f)).collect();
    let chosen = if chosen.is_empty() {
        FAMILIES.to_vec()
    } else {
        chosen
    };
    println!("noise model: {model:?}");
    let noises = if noises.is_empty() {
        vec![0.02, 0.05]
    } else {
        noises
    };
    println!(
        "{:<14} {:>5} {:>10} {:>7} {:>9} {:>9} {:>10} {:>9} {:>8} {:>9}",
        "family",
        "noise",
        "success",
        "missed",
        "spurious",
        "duplicate",
        "med NFD",
        "med NDD",
        "med MAC",
        "CPU s"
    );
    for &noise in &noises {
        for &name in &chosen {
            // The large family costs seconds per case: a quarter of the seeds.
            let n = if name == "large" {
                (seeds / 4).max(1)
            } else {
                seeds
            };
            family(name, noise, n, model);
        }
    }
}

fn scale() {
    let c = case("large", 1).unwrap_or_else(|| unreachable!("a known family"));
    let d = frf_data(&c, 0.02, 1);
    println!(
        "PUB5 size: {} outputs × {} references × {} lines, {} threads",
        d.n_out(),
        d.n_ref(),
        d.n_lines(),
        rayon::current_num_threads()
    );
    let t = cpu_seconds();
    let orders = polymax(&d, &PolymaxParams { max_order: 50 }).expect("polymax");
    println!("PolyMAX orders 1..=50: {:.2} s CPU", cpu_seconds() - t);
    drop(orders);
    let t = cpu_seconds();
    let r = auto_ema(&d, &AutoEmaParams::default(), &|| {}).expect("auto_ema");
    let s = score(&c, 0.02, &estimates(&r), r.best.mean_frac);
    println!(
        "auto_ema (orders up to {}, {} BO steps): {:.2} s CPU; found {}/{}, spurious {}, duplicate {}, mean FRAC {:.5}",
        r.orders.len(),
        r.trace.len(),
        cpu_seconds() - t,
        s.found,
        s.visible,
        s.spurious,
        s.duplicate,
        r.best.mean_frac
    );
}

/// `real [LO HI [ITERATIONS [FILES]]]` (module docs).
fn real(args: &[String]) -> Result<(), String> {
    use modalflow::ema::layout::{frf_data, Reciprocity};
    use modalflow::io::{frf_sets_from_uff, read_uff, FrfImportOptions};
    let num = |k: usize, default: f64| args.get(k).and_then(|s| s.parse().ok()).unwrap_or(default);
    let band = (num(0, 5.0), num(1, 800.0));
    let evaluations = num(2, 40.0) as usize;
    let files = args.get(3).map_or(
        "frf_hammer_as_measured.uff,frf_shaker.uff,frf_mimo_2ref.uff",
        String::as_str,
    );
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/real/beam_ufsc_ss"
    );
    for file in files.split(',') {
        let bytes = std::fs::read(format!("{dir}/{file}")).map_err(|e| format!("{file}: {e}"))?;
        let uff = read_uff(&bytes, file).map_err(|e| e.to_string())?;
        let sets = frf_sets_from_uff(&uff, file, &FrfImportOptions::default())
            .map_err(|e| e.to_string())?
            .sets;
        let set = sets.first().ok_or(format!("{file}: no FRFs"))?;
        let (d, layout) = frf_data(set, Some(band), Weighting::Uniform, Reciprocity::Auto)
            .map_err(|e| e.to_string())?;
        println!("{file}, {:?} Hz: {}", band, layout.description);
        for design in 0..8 {
            let p = AutoEmaParams {
                design,
                evaluations,
                initial: 12.min(evaluations),
                ..AutoEmaParams::default()
            };
            let t = cpu_seconds();
            let r = auto_ema(&d, &p, &|| {}).map_err(|e| e.to_string())?;
            let f: Vec<String> = r
                .best
                .roots
                .iter()
                .map(|x| format!("{:.1}", x.pole(&r.orders).frequency_hz))
                .collect();
            println!(
                "  design {design}: {:>2} modes, {:>3} evaluations, order {:>3} of {:?}, mean FRAC {:.4}, {:.1} s CPU: {}",
                f.len(),
                r.trace.len(),
                r.best.hyperparameters.max_order,
                r.bounds[8],
                r.best.mean_frac,
                cpu_seconds() - t,
                f.join(" ")
            );
        }
    }
    Ok(())
}

/// `export DIR FAMILY SEED NOISE [POSITIONS]`.
fn export(args: &[String]) -> Result<(), String> {
    let [dir, name, seed, noise, rest @ ..] = args else {
        return Err("usage: export DIR FAMILY SEED NOISE [POSITIONS]".into());
    };
    let seed: u64 = seed.parse().map_err(|e| format!("seed: {e}"))?;
    let noise: f64 = noise.parse().map_err(|e| format!("noise: {e}"))?;
    let positions: u32 = rest
        .first()
        .map_or(Ok(1), |p| p.parse())
        .map_err(|e| format!("positions: {e}"))?;
    let c = case(name, seed).ok_or(format!("unknown family {name}"))?;
    let dir = std::path::Path::new(dir);
    let sets: Vec<_> = (0..positions)
        .map(|p| {
            let noise_seed = seed + 1000 * u64::from(p);
            let mut set = frf_set(&c, noise, noise_seed);
            set.position = modalflow::frf::Position {
                index: p,
                label: format!("p{p}"),
            };
            set
        })
        .collect();
    let io = |e: std::io::Error| e.to_string();
    std::fs::write(
        dir.join("frf.uff"),
        modalflow::io::write_frf_artifact(&sets),
    )
    .map_err(io)?;
    let mut bin = Vec::new();
    for ch in &sets[0].channels {
        for v in &ch.values {
            bin.extend_from_slice(&v.re.to_le_bytes());
            bin.extend_from_slice(&v.im.to_le_bytes());
        }
    }
    std::fs::write(dir.join("frf.bin"), bin).map_err(io)?;
    let modes: Vec<serde_json::Value> = c
        .modes
        .iter()
        .map(|m| {
            serde_json::json!({"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio, "shape": m.shape})
        })
        .collect();
    let json = serde_json::json!({
        "family": name, "seed": seed, "noise": noise,
        "frequencies_hz": c.frequencies_hz,
        "references": c.references,
        "n_out": c.modes[0].shape.len(),
        "visibility": modalflow::ema::families::visibility(&c, noise),
        "modes": modes,
    });
    std::fs::write(dir.join("case.json"), json.to_string()).map_err(io)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    match args.first().map(String::as_str) {
        Some("export") => {
            if let Err(e) = export(&args[1..]) {
                eprintln!("export: {e}");
                std::process::exit(2);
            }
        }
        Some("families") => families(&args[1..]),
        Some("real") => {
            if let Err(e) = real(&args[1..]) {
                eprintln!("real: {e}");
                std::process::exit(2);
            }
        }
        Some("scale") => scale(),
        _ => polymax_reuse(),
    }
}
