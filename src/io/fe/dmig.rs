//! Nastran DMIG bulk entries (MSC Nastran Quick Reference Guide, "DMIG"),
//! as a punch file from `EXTSEOUT(…, DMIGPCH)` or `PARAM,EXTOUT,DMIGPCH`
//! holds reduced stiffness (`KAAX`) and mass (`MAAX`) matrices:
//!
//! ```text
//! DMIG    NAME    0       IFO     TIN     TOUT    POLAR           NCOL   (header)
//! DMIG    NAME    GJ      CJ              G1      C1      A1      B1     (column GJ/CJ)
//!         G2      C2      A2      B2      …                              (continuations)
//! ```
//!
//! in small field (8 columns), large field (`DMIG*`, 16 columns, `*`
//! continuations) or free field (commas); a `D` or a bare exponent sign
//! (`1.5+3`) is read as in Nastran. Real matrices (TIN 1, 2) with IFO 6
//! (symmetric, one triangle given) or 1 (square) are read; rows are numbered
//! by (grid, component) in ascending order and carry those labels.

use super::{fail, number_labels, parse_real, DofLabel, FeError, FeMatrix};

/// One logical card: its first line and its data fields (after `DMIG`).
struct Card {
    line: usize,
    fields: Vec<String>,
}

fn physical_fields(line: &str) -> (bool, Vec<String>) {
    if line.contains(',') {
        let mut t = line.split(',');
        let key = t.next().unwrap_or("").trim().to_string();
        return (
            key.ends_with('*'),
            t.map(|s| s.trim().to_string()).collect(),
        );
    }
    let key = line.get(..8.min(line.len())).unwrap_or("").trim();
    let large = key.ends_with('*');
    let width = if large { 16 } else { 8 };
    let body: String = line.chars().skip(8).take(64).collect();
    let chars: Vec<char> = body.chars().collect();
    let fields = chars
        .chunks(width)
        .map(|c| c.iter().collect::<String>().trim().to_string())
        .collect();
    (large, fields)
}

fn cards(text: &str) -> Vec<Card> {
    let mut out: Vec<Card> = Vec::new();
    let mut open = false;
    for (k, line) in text.lines().enumerate() {
        let upper = line.trim_start().to_ascii_uppercase();
        if upper.starts_with("DMIG") {
            let (_, f) = physical_fields(line.trim_start());
            out.push(Card {
                line: k + 1,
                fields: f,
            });
            open = true;
        } else if open
            && (line.starts_with('*')
                || line.starts_with('+')
                || line.starts_with(',')
                || line.starts_with("        "))
        {
            if let Some(c) = out.last_mut() {
                let (_, f) = physical_fields(line);
                c.fields.extend(f);
            }
        } else {
            open = false;
        }
    }
    out
}

fn int(card: &Card, i: usize, what: &str) -> Result<i64, FeError> {
    let f = card.fields.get(i).map(String::as_str).unwrap_or("");
    f.parse::<i64>()
        .or_else(|_| fail(card.line, format!("{what} `{f}` is not an integer")))
}

fn label(card: &Card, i: usize) -> Result<DofLabel, FeError> {
    let g = int(card, i, "grid")?;
    let c = int(card, i + 1, "component")?;
    if g < 0 || !(1..=6).contains(&c) {
        return fail(
            card.line,
            format!("grid {g} component {c}: only grid points with components 1..6 are read"),
        );
    }
    Ok((g as u64, c as u8))
}

/// Read the DMIG matrix `name` (e.g. `KAAX`) from a punch or bulk file.
pub fn read_dmig(text: &str, name: &str) -> Result<FeMatrix, FeError> {
    let all = cards(text);
    let mine: Vec<&Card> = all
        .iter()
        .filter(|c| {
            c.fields
                .first()
                .is_some_and(|n| n.eq_ignore_ascii_case(name))
        })
        .collect();
    let Some(header) = mine
        .iter()
        .find(|c| c.fields.get(1).map(String::as_str) == Some("0"))
    else {
        let mut names: Vec<&str> = all
            .iter()
            .filter_map(|c| c.fields.first().map(String::as_str))
            .collect();
        names.sort_unstable();
        names.dedup();
        return fail(
            1,
            format!("no DMIG header for matrix `{name}`; the file has {names:?}"),
        );
    };
    let ifo = int(header, 2, "IFO")?;
    let tin = int(header, 3, "TIN")?;
    if !(tin == 1 || tin == 2) {
        return fail(
            header.line,
            format!("TIN = {tin}: only real matrices (1, 2) are read"),
        );
    }
    if !(ifo == 6 || ifo == 1) {
        return fail(
            header.line,
            format!("IFO = {ifo}: only symmetric (6) or square (1) matrices are read"),
        );
    }
    let mut labelled = Vec::new();
    for card in mine.iter().filter(|c| c.line != header.line) {
        let column = label(card, 1)?;
        let mut i = 4;
        while i < card.fields.len() {
            if card.fields[i].is_empty() {
                i += 4;
                continue;
            }
            let row = label(card, i)?;
            let f = card.fields.get(i + 2).map(String::as_str).unwrap_or("");
            let v = parse_real(f).ok_or_else(|| FeError {
                line: card.line,
                message: format!(
                    "value `{f}` of row {row:?}, column {column:?} is not a finite number"
                ),
            })?;
            labelled.push((row, column, v));
            i += 4;
        }
    }
    if labelled.is_empty() {
        return fail(
            header.line,
            format!("matrix `{name}` has no column entries"),
        );
    }
    let lower = labelled.iter().all(|(a, b, _)| a >= b);
    let upper = labelled.iter().all(|(a, b, _)| a <= b);
    Ok(number_labels(labelled, ifo == 6 && (lower || upper)))
}
