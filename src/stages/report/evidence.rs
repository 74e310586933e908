//! The evidence a reviewer asks for first: the initial and the updated
//! models against the same reference — FRAC and CSF of the FRFs, paired
//! modes, MAC and frequency deviation (NFD) — side by side, then per
//! reference mode, as a table and a figure.
//!
//! The updated models are the `metrics` (and `tables`) of the evaluate
//! stages; the initial model is an evaluate stage of its own bound to
//! `initial` and `initial_tables` (its modes and FRFs against the same
//! reference). Without it, the initial FRAC/CSF still come from an
//! evaluate's `initial_frf` input.

use super::{sig4, verdicts::ok_cell};
use crate::artifacts::metrics::Metrics;
use crate::report::document::{Document, FAIL};
use crate::report::svg::{stacked, Plot, Series, PALETTE};
use crate::stages::StageError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The name to show for an evaluate stage: the values of a matrix stage
/// (`score[run=guided]` → `guided`), else the stage.
pub fn short(stage: &str) -> String {
    match (stage.find('['), stage.rfind(']')) {
        (Some(a), Some(b)) if b > a => stage[a + 1..b]
            .split(',')
            .map(|kv| kv.split_once('=').map_or(kv, |(_, v)| v))
            .collect::<Vec<_>>()
            .join(", "),
        _ => stage.to_string(),
    }
}

/// One model in the comparison: its column name, metrics and pairs.
struct Column<'a> {
    name: String,
    metrics: Option<&'a Metrics>,
    pairs: Pairs,
}

/// pairs.csv of one evaluate: (position, reference mode) → (reference Hz,
/// candidate Hz, MAC).
type Pairs = BTreeMap<(u32, usize), (f64, f64, f64)>;

fn read_pairs(dir: &Path) -> Pairs {
    let Ok(text) = std::fs::read_to_string(dir.join("pairs.csv")) else {
        return Pairs::new();
    };
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n);
    let cols = [
        col("position"),
        col("reference_mode"),
        col("reference_hz"),
        col("candidate_hz"),
        col("MAC"),
    ];
    let [Some(p), Some(m), Some(rh), Some(ch), Some(mac)] = cols else {
        return Pairs::new();
    };
    let mut out = Pairs::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
        let (Some(pos), Some(mode)) = (
            f.get(p).and_then(|v| v.parse().ok()),
            f.get(m).and_then(|v| v.parse().ok()),
        ) else {
            continue;
        };
        if let (Some(r), Some(c)) = (num(rh), num(ch)) {
            out.insert((pos, mode), (r, c, num(mac).unwrap_or(f64::NAN)));
        }
    }
    out
}

/// The initial model against the reference, then each updated one.
pub fn initial_vs_updated(
    doc: &mut Document,
    initial: Option<(&Metrics, Option<&PathBuf>)>,
    updated: &[(String, Metrics)],
    tables: &[(String, PathBuf)],
) -> Result<(), StageError> {
    let initial_frac = updated
        .iter()
        .find_map(|(_, m)| m.frf.as_ref().and_then(|f| f.initial_mean_frac));
    if updated.is_empty() || (initial.is_none() && initial_frac.is_none()) {
        return Ok(());
    }
    let mut columns = vec![Column {
        name: "initial model".into(),
        metrics: initial.map(|(m, _)| m),
        pairs: initial
            .and_then(|(_, t)| t)
            .map_or_else(Pairs::new, |t| read_pairs(t)),
    }];
    for (stage, m) in updated {
        let dir = tables.iter().find(|(s, _)| s == stage).map(|(_, d)| d);
        columns.push(Column {
            name: short(stage),
            metrics: Some(m),
            pairs: dir.map_or_else(Pairs::new, |d| read_pairs(d)),
        });
    }
    doc.heading(2, "Initial vs updated model");
    doc.paragraph(
        "Each model against the same reference: FRAC and CSF of the FRFs (1 = identical), the \
         modes paired by frequency and shape, their MAC and frequency deviation NFD = |f − f_ref|/f_ref.",
    );
    summary_table(doc, &columns, updated, initial_frac);
    per_mode(doc, &columns);
    Ok(())
}

fn summary_table(
    doc: &mut Document,
    columns: &[Column<'_>],
    updated: &[(String, Metrics)],
    initial_frac: Option<f64>,
) {
    let initial_csf = updated
        .iter()
        .find_map(|(_, m)| m.frf.as_ref().and_then(|f| f.initial_mean_csf));
    type Cell = fn(&Metrics) -> Option<String>;
    let rows: [(&str, Cell); 8] = [
        ("mean FRAC", |m| {
            m.frf.as_ref()?.mean_frac.map(|v| sig4(Some(v)))
        }),
        ("mean CSF", |m| {
            m.frf.as_ref()?.mean_csf.map(|v| sig4(Some(v)))
        }),
        ("paired modes", |m| {
            let x = m.modes.as_ref()?;
            let cell = format!("{}/{}", x.paired, x.reference_modes);
            Some(if x.paired < x.reference_modes {
                format!("{FAIL} {cell}")
            } else {
                cell
            })
        }),
        ("mean MAC", |m| m.modes.as_ref()?.mean_mac.map(mac_cell)),
        ("min MAC", |m| {
            let x = m.modes.as_ref()?;
            let min = x
                .positions
                .iter()
                .filter_map(|p| p.min_mac)
                .reduce(f64::min);
            min.map(mac_cell)
        }),
        ("mean NFD %", |m| {
            m.modes.as_ref()?.mean_nfd.map(|v| sig4(Some(100.0 * v)))
        }),
        ("max NFD %", |m| {
            let x = m.modes.as_ref()?;
            let max = x
                .positions
                .iter()
                .filter_map(|p| p.max_nfd)
                .reduce(f64::max);
            max.map(|v| sig4(Some(100.0 * v)))
        }),
        ("parameter error vs truth, mean %", |m| {
            m.parameters
                .as_ref()?
                .mean_abs_relative_error
                .map(|v| sig4(Some(100.0 * v)))
        }),
    ];
    let mut table: Vec<Vec<String>> = rows
        .iter()
        .map(|(name, f)| {
            let mut row = vec![name.to_string()];
            row.extend(
                columns
                    .iter()
                    .map(|c| c.metrics.and_then(f).unwrap_or_else(|| "–".into())),
            );
            row
        })
        .collect();
    // The initial FRF criteria from an evaluate's `initial_frf` when the
    // initial model has no evaluate of its own.
    for (k, v) in [(0, initial_frac), (1, initial_csf)] {
        if table[k][1] == "–" {
            if let Some(v) = v {
                table[k][1] = sig4(Some(v));
            }
        }
    }
    let mut verdict = vec!["verdict".to_string()];
    verdict.extend(columns.iter().map(|c| {
        c.metrics
            .and_then(|m| m.verdict.as_ref())
            .map_or("–".into(), ok_cell)
    }));
    table.push(verdict);
    let mut header = vec!["criterion".to_string()];
    header.extend(columns.iter().map(|c| c.name.clone()));
    doc.table(header, table);
}

/// Per reference mode: frequency deviation and MAC of each model, as a
/// table and a figure.
fn per_mode(doc: &mut Document, columns: &[Column<'_>]) {
    let mut keys: BTreeMap<(u32, usize), f64> = BTreeMap::new();
    for c in columns {
        for (k, v) in &c.pairs {
            keys.entry(*k).or_insert(v.0);
        }
    }
    if keys.is_empty() {
        return;
    }
    let mut header = vec![
        "position".to_string(),
        "mode".into(),
        "reference [Hz]".into(),
    ];
    for c in columns {
        header.push(format!("{} Δf %", c.name));
        header.push(format!("{} MAC", c.name));
    }
    let rows = keys
        .iter()
        .map(|(&(pos, mode), &f_ref)| {
            let mut row = vec![pos.to_string(), mode.to_string(), sig4(Some(f_ref))];
            for c in columns {
                match c.pairs.get(&(pos, mode)) {
                    Some(&(r, f, mac)) => {
                        row.push(signed(100.0 * (f - r) / r));
                        row.push(mac_cell(mac));
                    }
                    None if c.pairs.is_empty() => row.extend(["–".into(), "–".into()]),
                    None => row.extend([format!("{FAIL} missed"), "–".into()]),
                }
            }
            row
        })
        .collect();
    doc.heading(3, "Per reference mode");
    doc.table(header, rows);
    let fig = figure(columns);
    doc.figure(fig.0, "initial_vs_updated.svg", fig.1);
}

/// A MAC to 4 decimals (`0.9999`, not `1`); `–` when not computed.
fn mac_cell(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "–".into()
    }
}

/// `+1.23` / `−0.456`: a signed deviation to 3 significant digits.
fn signed(v: f64) -> String {
    let s = crate::report::format::sig(v, 3);
    if v > 0.0 {
        format!("+{s}")
    } else {
        s.replacen('-', "−", 1)
    }
}

fn figure(columns: &[Column<'_>]) -> (String, String) {
    let mut nfd = Plot::new("", "reference frequency [Hz]", "f − f_ref [% of f_ref]");
    nfd.height = 220.0;
    let mut mac = Plot::new("", "reference frequency [Hz]", "MAC [–]");
    mac.height = 180.0;
    for (k, c) in columns.iter().enumerate() {
        if c.pairs.is_empty() {
            continue;
        }
        // The initial model in grey, the updated ones in the palette.
        let colour = if k == 0 {
            "#7a7a7a"
        } else {
            PALETTE[(k - 1) % PALETTE.len()]
        };
        let dev = c
            .pairs
            .values()
            .map(|&(r, f, _)| (r, 100.0 * (f - r) / r))
            .collect();
        let m = c.pairs.values().map(|&(r, _, m)| (r, m)).collect();
        nfd.series
            .push(Series::points(c.name.clone(), dev, colour, 3.5));
        mac.series
            .push(Series::points(c.name.clone(), m, colour, 3.5));
    }
    // The reference: zero deviation, drawn beneath over the band.
    let xs = columns.iter().flat_map(|c| c.pairs.values().map(|p| p.0));
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    if lo.is_finite() {
        nfd.series.insert(
            0,
            Series::reference("reference", vec![(lo, 0.0), (hi, 0.0)]),
        );
    }
    let caption = "Frequency deviation (top) and MAC (bottom) of every paired reference mode, initial model (grey) and updated models, over the reference frequency; a reference mode without a partner has no point";
    (
        caption.to_string(),
        stacked(
            "Initial vs updated: modes against the reference",
            caption,
            &[nfd, mac],
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::{short, signed};

    #[test]
    fn names_and_signs() {
        assert_eq!(short("score[run=guided]"), "guided");
        assert_eq!(short("s[a=1,b=x]"), "1, x");
        assert_eq!(short("score"), "score");
        assert_eq!(signed(1.234_56), "+1.23");
        assert_eq!(signed(-0.045_67), "−0.0457");
        assert_eq!(super::mac_cell(0.999_97), "1.0000");
        assert_eq!(super::mac_cell(f64::NAN), "–");
    }
}
