//! Analysis of variance for factorial designs (seed section 2.1.1,
//! eq. 2.2–2.5; Siebertz et al. 2017), as used for the wear screening of PUB1:
//! main effects and, optionally, all two-factor interactions.
//!
//! - main effect of factor i, eq. 2.2: SSBᵢ = Σ_j N̂ᵢⱼ (ȳᵢⱼ − ȳ)², DOF = levels − 1
//! - interaction a:b: SS = Σ_cells N̂ (ȳ_ab − ȳ)² − SS_a − SS_b, DOF = (Lₐ−1)(L_b−1)
//! - MS = SS / DOF (eq. 2.3), F = MS / MS_residual (eq. 2.4), residual =
//!   TSS (eq. 2.5) minus all other SS, p = P(F(DOF, DOF_res) > F).
//!
//! These sums of squares are orthogonal, and equal the type I, II and III
//! sums of squares of a linear model, only for balanced designs: with two or
//! more factors every combination of levels must occur equally often, and an
//! unbalanced table is rejected (with the cell counts) rather than given
//! order-dependent results. One factor may be unbalanced (eq. 2.2 is then
//! exact one-way ANOVA).

#![allow(non_snake_case)]

use super::SensitivityError;
use statrs::distribution::{ContinuousCDF, FisherSnedecor};
use std::collections::BTreeMap;

/// A categorical factor: its level labels (in order of first appearance) and
/// the level of every observation.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    pub name: String,
    pub levels: Vec<String>,
    pub codes: Vec<usize>,
}

impl Factor {
    /// Code the labels of every observation by first appearance.
    pub fn from_labels(name: impl Into<String>, labels: &[String]) -> Factor {
        let mut levels: Vec<String> = Vec::new();
        let codes = labels
            .iter()
            .map(|l| match levels.iter().position(|x| x == l) {
                Some(i) => i,
                None => {
                    levels.push(l.clone());
                    levels.len() - 1
                }
            })
            .collect();
        Factor {
            name: name.into(),
            levels,
            codes,
        }
    }
}

/// Factors and the response of every observation.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    pub factors: Vec<Factor>,
    pub response: Vec<f64>,
}

impl Design {
    /// Read a CSV table (header row; `#` comments) of factor levels and a
    /// numeric response column. `factors` selects factor columns in the given
    /// order; `None` takes every column but the response, in file order.
    /// `file` names the table in error messages.
    pub fn from_csv(
        text: &str,
        file: &str,
        response: &str,
        factors: Option<&[String]>,
    ) -> Result<Design, SensitivityError> {
        let table = |line: u64, message: String| SensitivityError::Table {
            file: file.to_string(),
            line,
            message,
        };
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| table(1, e.to_string()))?
            .iter()
            .map(str::to_string)
            .collect();
        let column = |name: &str| {
            header.iter().position(|h| h == name).ok_or_else(|| {
                table(
                    1,
                    format!("no column `{name}`; the columns are: {}", header.join(", ")),
                )
            })
        };
        let r = column(response)?;
        let factor_cols: Vec<usize> = match factors {
            Some(names) => names.iter().map(|n| column(n)).collect::<Result<_, _>>()?,
            None => (0..header.len()).filter(|&c| c != r).collect(),
        };
        if factor_cols.is_empty() {
            return Err(table(
                1,
                "the table has no factor column besides the response".into(),
            ));
        }
        let mut y = Vec::new();
        let mut labels: Vec<Vec<String>> = vec![Vec::new(); factor_cols.len()];
        for record in reader.records() {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line());
                table(line, e.to_string())
            })?;
            let line = record.position().map_or(0, |p| p.line());
            let cell = record.get(r).unwrap_or_default();
            let v: f64 = cell.parse().map_err(|_| {
                table(
                    line,
                    format!("response `{response}` = `{cell}` is not a number"),
                )
            })?;
            if !v.is_finite() {
                return Err(table(
                    line,
                    format!("response `{response}` = `{cell}` is not finite"),
                ));
            }
            y.push(v);
            for (k, &c) in factor_cols.iter().enumerate() {
                let label = record.get(c).unwrap_or_default();
                if label.is_empty() {
                    return Err(table(line, format!("factor `{}` is empty", header[c])));
                }
                labels[k].push(label.to_string());
            }
        }
        let factors = factor_cols
            .iter()
            .zip(&labels)
            .map(|(&c, l)| Factor::from_labels(header[c].clone(), l))
            .collect();
        Ok(Design {
            factors,
            response: y,
        })
    }
}

/// One row of the ANOVA table; `F` and `p` are `None` for the residual.
#[derive(Clone, Debug, PartialEq)]
pub struct AnovaRow {
    /// Factor name, `a:b` for an interaction, or `residual`.
    pub source: String,
    pub SS: f64,
    pub DOF: usize,
    pub MS: f64,
    pub F: Option<f64>,
    pub p: Option<f64>,
}

/// Σ over the groups of `key` of N̂ (ȳ_group − ȳ)².
fn between(y: &[f64], mean: f64, groups: usize, key: impl Fn(usize) -> usize) -> f64 {
    let mut sum = vec![0.0; groups];
    let mut count = vec![0usize; groups];
    for (j, v) in y.iter().enumerate() {
        sum[key(j)] += v;
        count[key(j)] += 1;
    }
    sum.iter()
        .zip(&count)
        .filter(|(_, &c)| c > 0)
        .map(|(s, &c)| c as f64 * (s / c as f64 - mean).powi(2))
        .sum()
}

/// Reject designs whose full factorial cells are not equally filled.
fn check_balance(design: &Design) -> Result<(), SensitivityError> {
    if design.factors.len() < 2 {
        return Ok(());
    }
    let mut cells: BTreeMap<Vec<usize>, usize> = BTreeMap::new();
    for j in 0..design.response.len() {
        let key = design.factors.iter().map(|f| f.codes[j]).collect();
        *cells.entry(key).or_default() += 1;
    }
    let expected: usize = design.factors.iter().map(|f| f.levels.len()).product();
    let counts: Vec<usize> = cells.values().copied().collect();
    if cells.len() != expected || counts.iter().any(|&c| c != counts[0]) {
        let (lo, hi) = (
            counts.iter().min().copied().unwrap_or(0),
            counts.iter().max().copied().unwrap_or(0),
        );
        let lo = if cells.len() != expected { 0 } else { lo };
        return Err(SensitivityError::Unbalanced(format!(
            "{} of {expected} level combinations occur, between {lo} and {hi} times each; \
             multi-factor ANOVA needs a balanced full factorial (every combination equally often). \
             Complete the design or analyze one factor at a time",
            cells.len()
        )));
    }
    Ok(())
}

/// The ANOVA table: main effects in factor order, then (with `interactions`
/// = 2) every pair `a:b` in factor order, then `residual`.
pub fn anova(design: &Design, interactions: u8) -> Result<Vec<AnovaRow>, SensitivityError> {
    let y = &design.response;
    let n = y.len();
    if !(1..=2).contains(&interactions) {
        return Err(SensitivityError::Invalid(format!(
            "interactions = {interactions}: use 1 (main effects) or 2 (with two-factor interactions)"
        )));
    }
    if design.factors.is_empty() || design.factors.iter().any(|f| f.codes.len() != n) {
        return Err(SensitivityError::Invalid(
            "every factor needs one level per observation".into(),
        ));
    }
    if let Some(f) = design.factors.iter().find(|f| f.levels.len() < 2) {
        return Err(SensitivityError::Invalid(format!(
            "factor `{}` has only one level; a factor needs at least two",
            f.name
        )));
    }
    check_balance(design)?;
    let mean = y.iter().sum::<f64>() / n as f64;
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let mut rows: Vec<AnovaRow> = Vec::new();
    let mut main = Vec::new();
    for f in &design.factors {
        let ss = between(y, mean, f.levels.len(), |j| f.codes[j]);
        main.push(ss);
        rows.push(row(f.name.clone(), ss, f.levels.len() - 1));
    }
    if interactions == 2 {
        let fs = &design.factors;
        for a in 0..fs.len() {
            for b in a + 1..fs.len() {
                let lb = fs[b].levels.len();
                let cells = between(y, mean, fs[a].levels.len() * lb, |j| {
                    fs[a].codes[j] * lb + fs[b].codes[j]
                });
                let dof = (fs[a].levels.len() - 1) * (lb - 1);
                let name = format!("{}:{}", fs[a].name, fs[b].name);
                rows.push(row(name, cells - main[a] - main[b], dof));
            }
        }
    }
    let used: usize = rows.iter().map(|r| r.DOF).sum();
    if used + 1 >= n {
        return Err(SensitivityError::Invalid(format!(
            "{n} observations leave no residual degrees of freedom for {used} model degrees of freedom; \
             replicate the design or use `interactions: 1`"
        )));
    }
    let dof_res = n - 1 - used;
    // Clamp: rounding may leave a perfect fit at −1e-15.
    let ss_res = (tss - rows.iter().map(|r| r.SS).sum::<f64>()).max(0.0);
    let ms_res = ss_res / dof_res as f64;
    for r in &mut rows {
        let (F, p) = if ms_res > 0.0 {
            let F = r.MS / ms_res;
            let dist = FisherSnedecor::new(r.DOF as f64, dof_res as f64)
                .map_err(|e| SensitivityError::Invalid(e.to_string()))?;
            (F, dist.sf(F))
        } else if r.MS > 0.0 {
            // No residual scatter at all: any effect is infinitely significant.
            (f64::INFINITY, 0.0)
        } else {
            (0.0, 1.0)
        };
        r.F = Some(F);
        r.p = Some(p);
    }
    rows.push(AnovaRow {
        source: "residual".into(),
        SS: ss_res,
        DOF: dof_res,
        MS: ms_res,
        F: None,
        p: None,
    });
    Ok(rows)
}

fn row(source: String, ss: f64, dof: usize) -> AnovaRow {
    AnovaRow {
        source,
        SS: ss,
        DOF: dof,
        MS: ss / dof as f64,
        F: None,
        p: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const COFFEE: &str = include_str!("testdata/coffee_anova.csv");

    fn get<'a>(rows: &'a [AnovaRow], s: &str) -> &'a AnovaRow {
        rows.iter().find(|r| r.source == s).unwrap()
    }

    #[test]
    fn coffee_table_2_2_of_the_seed() {
        let d = Design::from_csv(COFFEE, "coffee_anova.csv", "rating", None).unwrap();
        let rows = anova(&d, 2).unwrap();
        let sources: Vec<&str> = rows.iter().map(|r| r.source.as_str()).collect();
        assert_eq!(
            sources,
            [
                "sugar",
                "container",
                "temperature",
                "sugar:container",
                "sugar:temperature",
                "container:temperature",
                "residual"
            ]
        );
        // Seed table 2.2 (rounded to 2 decimals; p in percent).
        let expect = [
            ("sugar", 1.04, 1, 0.74, 40.56),
            ("temperature", 42.33, 2, 14.94, 0.03),
            ("container", 77.04, 1, 54.38, 0.0),
            ("sugar:temperature", 0.33, 2, 0.12, 88.99),
            ("sugar:container", 1.04, 1, 0.74, 40.56),
            ("container:temperature", 25.33, 2, 8.94, 0.31),
        ];
        for (s, ss, dof, f, p) in expect {
            let r = get(&rows, s);
            assert!((r.SS - ss).abs() < 0.005, "{s}: {r:?}");
            assert_eq!(r.DOF, dof);
            assert!((r.F.unwrap() - f).abs() < 0.005, "{s}: {r:?}");
            assert!((100.0 * r.p.unwrap() - p).abs() < 0.005, "{s}: {r:?}");
        }
        let res = get(&rows, "residual");
        assert!((res.SS - 19.83).abs() < 0.005 && res.DOF == 14);
    }

    /// Reference values computed offline with Python statsmodels 0.15 (not a test
    /// dependency): `anova_lm(ols(formula, data), typ=1)` on the same CSV with
    /// `rating ~ C(sugar) + C(container) + C(temperature)` plus the three
    /// pairwise `C(a):C(b)` terms (types 1 and 2 agree to 1e-13, the design
    /// being balanced), and of the main-effects model alone.
    /// Rows: (source, SS, DOF, F, p).
    #[test]
    fn coffee_matches_statsmodels() {
        let d = Design::from_csv(COFFEE, "coffee_anova.csv", "rating", None).unwrap();
        let two: [(&str, f64, usize, f64, f64); 6] = [
            (
                "sugar",
                1.0416666666666619,
                1,
                0.7352941176470555,
                0.40561297344925096,
            ),
            (
                "container",
                77.04166666666661,
                1,
                54.38235294117644,
                3.486585197998739e-06,
            ),
            (
                "temperature",
                42.33333333333333,
                2,
                14.941176470588236,
                0.0003364084585948619,
            ),
            (
                "sugar:container",
                1.0416666666666636,
                1,
                0.7352941176470568,
                0.40561297344925057,
            ),
            (
                "sugar:temperature",
                0.33333333333333265,
                2,
                0.11764705882352919,
                0.8898793676610384,
            ),
            (
                "container:temperature",
                25.333333333333336,
                2,
                8.941176470588237,
                0.00314806501962016,
            ),
        ];
        let one: [(&str, f64, usize, f64, f64); 3] = [
            (
                "sugar",
                1.0416666666666619,
                1,
                0.4252461951656202,
                0.5221423108616458,
            ),
            (
                "container",
                77.04166666666661,
                1,
                31.451208594449394,
                2.0824645502830945e-05,
            ),
            (
                "temperature",
                42.33333333333333,
                2,
                8.641002685765441,
                0.002143344682485486,
            ),
        ];
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
        for (interactions, expect, residual) in [
            (2, &two[..], (19.833333333333332, 14)),
            (1, &one[..], (46.54166666666667, 19)),
        ] {
            let rows = anova(&d, interactions).unwrap();
            assert_eq!(rows.len(), expect.len() + 1);
            for (s, ss, dof, f, p) in expect {
                let r = get(&rows, s);
                assert!(close(r.SS, *ss) && r.DOF == *dof, "{s}: {r:?}");
                assert!((r.MS - ss / *dof as f64).abs() < 1e-9, "{s}: {r:?}");
                assert!(close(r.F.unwrap(), *f), "{s}: {r:?}");
                // p absolutely to 1e-9 and relatively to 1e-9 as well.
                let rp = r.p.unwrap();
                assert!(
                    close(rp, *p) && (rp - p).abs() <= 1e-9 * p,
                    "{s}: {rp} vs {p}"
                );
            }
            let res = get(&rows, "residual");
            assert!(
                close(res.SS, residual.0) && res.DOF == residual.1,
                "{res:?}"
            );
            assert!(res.F.is_none() && res.p.is_none());
        }
    }

    #[test]
    fn one_way_unbalanced_is_exact() {
        // Groups {1,2,3} and {5,7}: ȳ = 3.6, SSB = 3·1.6² + 2·2.4² = 19.2,
        // residual = 2 + 2 = 4 on 3 DOF, F = 19.2 / (4/3) = 14.4.
        let labels: Vec<String> = ["a", "a", "a", "b", "b"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let d = Design {
            factors: vec![Factor::from_labels("g", &labels)],
            response: vec![1.0, 2.0, 3.0, 5.0, 7.0],
        };
        let rows = anova(&d, 1).unwrap();
        assert!((rows[0].SS - 19.2).abs() < 1e-12);
        assert!((rows[1].SS - 4.0).abs() < 1e-12);
        assert!((rows[0].F.unwrap() - 14.4).abs() < 1e-12);
        // F(1, 3) survival at 14.4 = 0.032119416050416794 (scipy.stats.f.sf, offline).
        assert!(
            (rows[0].p.unwrap() - 0.032119416050416794).abs() < 1e-12,
            "{:?}",
            rows[0]
        );
    }

    #[test]
    fn unbalanced_and_degenerate_designs_are_rejected() {
        let text = "a,b,y\n1,x,1\n1,y,2\n2,x,3\n2,x,4\n";
        let d = Design::from_csv(text, "t.csv", "y", None).unwrap();
        let e = anova(&d, 1).unwrap_err().to_string();
        assert!(e.contains("3 of 4 level combinations"), "{e}");
        let e = Design::from_csv("a,y\n1,2\n2,oops\n", "t.csv", "y", None).unwrap_err();
        assert!(e.to_string().contains("t.csv:3"), "{e}");
        let e = Design::from_csv("a,y\n1,2\n", "t.csv", "rating", None).unwrap_err();
        assert!(e.to_string().contains("no column `rating`"), "{e}");
        // 2×2 with one observation per cell and the interaction: no residual left.
        let d =
            Design::from_csv("a,b,y\n1,1,1\n1,2,2\n2,1,3\n2,2,5\n", "t.csv", "y", None).unwrap();
        assert!(anova(&d, 2).is_err());
        assert_eq!(anova(&d, 1).unwrap().last().unwrap().DOF, 1);
    }
}
