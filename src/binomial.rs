//! How much a success count out of a family of trials says about the rate
//! behind it: the Clopper–Pearson ("exact") interval of a binomial
//! proportion (Clopper & Pearson 1934, Biometrika 26:404). The families of
//! `benchmarks/` judge a method by k of n truths reaching a goal; with n = 20
//! a count of 19 is consistent with any rate from 75 % up, so a change that
//! moves the count by one or two has not been shown to change the rate.

use statrs::distribution::{Beta, ContinuousCDF};

/// The two-sided Clopper–Pearson interval at `level` (e.g. 0.95) for `k`
/// successes in `n` trials: [B⁻¹(α/2; k, n − k + 1), B⁻¹(1 − α/2; k + 1, n − k)]
/// with B⁻¹ the Beta quantile, 0 and 1 at the ends (k = 0, k = n). It holds
/// the true rate with probability at least `level` for every rate. `None`
/// without trials, with more successes than trials, or a `level` outside
/// (0, 1).
pub fn clopper_pearson(k: u64, n: u64, level: f64) -> Option<(f64, f64)> {
    if n == 0 || k > n || !(level > 0.0 && level < 1.0) {
        return None;
    }
    let alpha = 1.0 - level;
    // Both shape parameters are ≥ 1 wherever a quantile is taken.
    let quantile = |a: f64, b: f64, p: f64| Some(Beta::new(a, b).ok()?.inverse_cdf(p));
    let (k, n) = (k as f64, n as f64);
    let low = if k == 0.0 {
        0.0
    } else {
        quantile(k, n - k + 1.0, alpha / 2.0)?
    };
    let high = if k == n {
        1.0
    } else {
        quantile(k + 1.0, n - k, 1.0 - alpha / 2.0)?
    };
    Some((low, high))
}

#[cfg(test)]
mod tests {
    use super::clopper_pearson;

    /// Against scipy 1.x, `binomtest(k, n).proportion_ci(0.95, "exact")`.
    #[test]
    fn the_interval_matches_scipy() {
        for (k, n, low, high) in [
            (16, 20, 0.5633859970033314, 0.942666002949976),
            (19, 20, 0.7512672372279723, 0.998734910502044),
            (20, 20, 0.8315665290169145, 1.0),
            (0, 20, 0.0, 0.16843347098308548),
            (17, 20, 0.6210731734547044, 0.9679290628144552),
            (1, 1, 0.025, 1.0),
            (38, 40, 0.8308031360405823, 0.9938863534006533),
        ] {
            let (l, h) = clopper_pearson(k, n, 0.95).unwrap();
            assert!((l - low).abs() < 1e-9, "{k}/{n}: {l} vs {low}");
            assert!((h - high).abs() < 1e-9, "{k}/{n}: {h} vs {high}");
        }
    }

    /// A wider level gives a wider interval around k/n.
    #[test]
    fn the_interval_holds_the_observed_rate_and_widens_with_the_level() {
        let (l95, h95) = clopper_pearson(7, 10, 0.95).unwrap();
        let (l99, h99) = clopper_pearson(7, 10, 0.99).unwrap();
        assert!(l99 < l95 && l95 < 0.7 && 0.7 < h95 && h95 < h99);
    }

    /// Impossible counts and levels give no interval rather than a panic.
    #[test]
    fn impossible_counts_give_no_interval() {
        assert_eq!(clopper_pearson(3, 0, 0.95), None);
        assert_eq!(clopper_pearson(5, 4, 0.95), None);
        assert_eq!(clopper_pearson(2, 4, 1.0), None);
        assert_eq!(clopper_pearson(2, 4, f64::NAN), None);
    }
}
