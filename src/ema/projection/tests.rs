use super::*;
use crate::ema::lsfd::lsfd;
use crate::ema::synthetic::{four_mode_system, lines, modal_superposition};
use crate::ema::Weighting;
use crate::metrics::pole;

fn data(noise: f64) -> FrfData {
    let set = modal_superposition(
        &four_mode_system(),
        &[0, 3],
        &lines(20.0, 260.0, 0.5),
        noise,
        3,
    );
    FrfData::from_set(&set, None, Weighting::Uniform).unwrap()
}

/// Fits are the same to the bit whether every pole's columns are kept
/// or only two (recomputed when a Gram entry needs them), on whitened
/// data (the recomputed columns must be whitened like the first ones).
#[test]
fn dropping_columns_beyond_the_budget_changes_no_fit() {
    let mut d = data(0.02);
    d.line_weight = (0..d.n_lines()).map(|f| 1.0 + 0.01 * f as f64).collect();
    let (mut all, mut two) = (Projector::new(&d), Projector::new(&d));
    two.cap = 2;
    let modes = four_mode_system();
    let sets: Vec<Vec<Complex64>> = (0..6)
        .map(|k| {
            modes
                .iter()
                .enumerate()
                .filter(|(j, _)| (j + k) % 3 != 0)
                .map(|(j, m)| {
                    pole(
                        m.frequency_hz * (1.0 + 1e-3 * (k + j) as f64),
                        m.damping_ratio,
                    )
                })
                .collect()
        })
        .collect();
    for set in sets.iter().chain(sets.iter().rev()) {
        let (FitOutcome::Fit(a), FitOutcome::Fit(b)) = (all.fit(set), two.fit(set)) else {
            panic!("dependent")
        };
        // And both are the QR fit of the whitened data.
        let q = lsfd(&d, set).unwrap();
        for (k, res) in q.residues.iter().enumerate() {
            for (c, r) in res.iter().enumerate() {
                assert!((b.residue(k, c) - r).norm() < 1e-8 * r.norm().max(1e-12));
            }
        }
        assert_eq!((a.x, a.rss, a.frac), (b.x, b.rss, b.frac));
    }
    assert!(two.planar.len() <= 2 && all.planar.len() > 2);
}

/// The normal-equation fit equals the QR fit of [`lsfd`] (residues,
/// FRAC) and ΔRSS of a pole equals the RSS increase of refitting without it.
#[test]
fn gram_fit_matches_qr_lsfd_and_refits() {
    let d = data(0.02);
    let lambdas: Vec<Complex64> = four_mode_system()
        .iter()
        .map(|m| pole(m.frequency_hz * 1.001, m.damping_ratio))
        .collect();
    let mut p = Projector::new(&d);
    let FitOutcome::Fit(g) = p.fit(&lambdas) else {
        panic!("dependent")
    };
    let q = lsfd(&d, &lambdas).unwrap();
    for (k, res) in q.residues.iter().enumerate() {
        for (c, r) in res.iter().enumerate() {
            assert!(
                (g.residue(k, c) - r).norm() < 1e-8 * r.norm().max(1e-12),
                "pole {k} channel {c}"
            );
        }
    }
    let nf = d.n_lines();
    for c in 0..d.n_out() * d.n_ref() {
        let f = crate::metrics::frac(
            &d.h[c * nf..(c + 1) * nf],
            &q.reconstructed[c * nf..(c + 1) * nf],
        );
        assert!(
            (g.frac[c] - f).abs() < 1e-10,
            "channel {c}: {} vs {f}",
            g.frac[c]
        );
    }
    let without: Vec<Complex64> = lambdas
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != 2)
        .map(|(_, l)| *l)
        .collect();
    let FitOutcome::Fit(h) = p.fit(&without) else {
        panic!("dependent")
    };
    for (c, dr) in g.delta_rss(2).iter().enumerate() {
        let want = h.rss[c] - g.rss[c];
        assert!(
            (dr - want).abs() < 1e-7 * want.abs().max(g.rss[c]),
            "channel {c}: {dr} vs {want}"
        );
    }
}

#[test]
fn coincident_poles_are_reported_as_dependent() {
    let d = data(0.0);
    let l = pole(95.0, 0.015);
    let mut p = Projector::new(&d);
    match p.fit(&[pole(60.0, 0.01), l, l]) {
        FitOutcome::Dependent(k) => assert_eq!(k, 2),
        FitOutcome::Fit(_) => panic!("identical poles must be dependent"),
    }
}

/// The residuals over the lines are the data less the QR fit of [`lsfd`],
/// channel by channel, and their squared norm is the fit's RSS.
#[test]
fn residuals_are_the_data_less_the_qr_fit() {
    let d = data(0.02);
    let lambdas: Vec<Complex64> = four_mode_system()
        .iter()
        .take(3)
        .map(|m| pole(m.frequency_hz * 1.002, m.damping_ratio))
        .collect();
    let mut p = Projector::new(&d);
    p.cap = 1; // columns recomputed as they are needed
    let FitOutcome::Fit(g) = p.fit(&lambdas) else {
        panic!("dependent")
    };
    let q = lsfd(&d, &lambdas).unwrap();
    let nf = d.n_lines();
    let channels = [3, 0];
    let r = p.residuals(&lambdas, &g, &channels);
    for (rc, &c) in r.iter().zip(&channels) {
        let scale = d.h[c * nf..(c + 1) * nf]
            .iter()
            .map(|h| h.norm())
            .fold(0.0, f64::max);
        for (f, v) in rc.iter().enumerate() {
            let want = d.h[c * nf + f] - q.reconstructed[c * nf + f];
            assert!(
                (v - want).norm() < 1e-9 * scale,
                "channel {c} line {f}: {v} vs {want}"
            );
        }
        let rss: f64 = rc.iter().map(|v| v.norm_sqr()).sum();
        assert!(
            (rss / g.rss[c] - 1.0).abs() < 1e-6,
            "channel {c}: {rss} vs {}",
            g.rss[c]
        );
    }
}
