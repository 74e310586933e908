//! PolyMAX for every order up to 60 on 30 outputs × 3 references × 1601
//! lines: normal equations built once and reused across orders (the
//! implementation) against the per-order rebuild of the normal equations
//! from the data (the reference), in the same run; plus the cost of one
//! Bayesian-optimization step (re-selection from the computed poles).
//!
//! `cargo bench --bench polymax`

mod timing;

use timing::best;

/// [`best`] in milliseconds.
fn best_ms<T>(n: usize, f: impl FnMut() -> T) -> (f64, T) {
    let (s, out) = best(n, f);
    (s * 1e3, out)
}

use modalflow::ema::synthetic::{lines, modal_superposition, SyntheticMode};
use modalflow::ema::{
    polymax, polymax_rebuild_per_order, select_modes, FrfData, Hyperparameters, PolymaxParams,
    Weighting,
};

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

fn main() {
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
    let (t_step, sel) = best_ms(10, || {
        select_modes(&data, &orders, &h, 0.002).expect("selection")
    });
    println!(
        "one BO step (stabilize, cluster, LSFD, FRAC): {:.2} ms; {} modes, mean FRAC {:.4}",
        t_step,
        sel.clusters.len(),
        sel.mean_frac
    );
    // The loosest corner of the search box: most poles pass as stable.
    let loose = Hyperparameters {
        frequency_tol: 0.05,
        damping_tol: 0.5,
        mac_tol: 0.2,
        max_damping: 0.2,
        cluster_distance: 0.1,
        ..h
    };
    let (t_loose, sel) = best_ms(3, || {
        select_modes(&data, &orders, &loose, 0.002).expect("selection")
    });
    let stable = sel.flags.iter().flatten().filter(|f| f.stable()).count();
    println!(
        "one BO step, loosest tolerances: {:.2} ms; {} stable poles clustered, {} modes",
        t_loose,
        stable,
        sel.clusters.len()
    );
}
