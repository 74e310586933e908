//! The CSV FRF table (`frf.csv`, format in the [`io`](crate::io) module docs):
//! one row per position and frequency line, `re:`/`im:`/`coh:` columns per
//! channel, optional `position`/`position_label` columns and a
//! `# quantity: …` metadata line.

use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use crate::io::csv_table::{csv_err, fmt_f64, from_csv_error, metadata, quantity_name, real_cell};
use crate::io::dof_text::{format_channel, parse_channel};
use crate::io::error::{IoError, Location, Place};
use crate::io::limits::BYTES_PER_CSV_CELL;
use crate::io::validity::{check_coherence_with, check_frequency, CoherencePolicy};
use num_complex::Complex64;
use std::collections::{HashMap, HashSet};

/// A channel's columns: name, DOFs, re, im and coherence column.
type Channel = (String, (Dof, Dof), usize, usize, Option<usize>);

struct Columns {
    frequency: usize,
    position: Option<usize>,
    label: Option<usize>,
    /// (channel, its DOFs, re column, im column, coherence column)
    channels: Vec<Channel>,
}

/// The header's columns, in time linear in their number: names are looked
/// up in a hash map (first occurrence wins), not searched column by column.
fn columns(headers: &csv::StringRecord, source: &str, line: usize) -> Result<Columns, IoError> {
    let mut index: HashMap<&str, usize> = HashMap::with_capacity(headers.len());
    for (i, h) in headers.iter().enumerate() {
        index.entry(h).or_insert(i);
    }
    let find = |name: &str| index.get(name).copied();
    let frequency = find("frequency_hz").ok_or_else(|| {
        csv_err(
            source,
            line,
            "no `frequency_hz` column; name the frequency column so",
        )
    })?;
    let mut channels: Vec<Channel> = Vec::new();
    let mut seen: HashSet<(Dof, Dof)> = HashSet::new();
    let mut key = String::new();
    for (i, h) in headers.iter().enumerate() {
        if matches!(h, "frequency_hz" | "position" | "position_label") {
            continue;
        }
        let Some((kind, ch)) = h.split_once(':') else {
            return Err(csv_err(
                source,
                line,
                format!("unknown column {h:?}; expected frequency_hz, position, position_label, re:/im:/coh:<response>/<reference>"),
            ));
        };
        let (r, f) = parse_channel(ch).ok_or_else(|| {
            csv_err(
                source,
                line,
                format!("column {h:?}: channel must read like 101+X/1-Z"),
            )
        })?;
        let mut partner = |k: &str| {
            key.clear();
            key.push_str(k);
            key.push(':');
            key.push_str(ch);
            find(&key)
        };
        match kind {
            "re" => {
                let im = partner("im").ok_or_else(|| {
                    csv_err(
                        source,
                        line,
                        format!("column {h:?} has no `im:{ch}` partner"),
                    )
                })?;
                let coh = partner("coh");
                let name = format_channel(r, f);
                if !seen.insert((r, f)) {
                    return Err(csv_err(
                        source,
                        line,
                        format!("channel {name} appears twice"),
                    ));
                }
                channels.push((name, (r, f), i, im, coh));
            }
            "im" | "coh" => {
                if partner("re").is_none() {
                    return Err(csv_err(
                        source,
                        line,
                        format!("column {h:?} has no `re:{ch}` partner"),
                    ));
                }
            }
            _ => {
                return Err(csv_err(
                    source,
                    line,
                    format!("column {h:?}: prefix must be re, im or coh"),
                ))
            }
        }
    }
    Ok(Columns {
        frequency,
        position: find("position"),
        label: find("position_label"),
        channels,
    })
}

/// One position's rows: frequency, FRF cells and coherence cells per channel.
struct Rows {
    position: Position,
    first_line: usize,
    lines: Vec<usize>,
    freqs: Vec<f64>,
    cells: Vec<Vec<Option<Complex64>>>,
    coh: Vec<Vec<Option<f64>>>,
}

/// Reads a CSV FRF table; `source` names it in errors. Time is linear in
/// the table's size; frequencies (≥ 0, strictly increasing per position)
/// and coherences (in [0, 1]) are checked as each row is read.
pub fn read_frf_csv(bytes: &[u8], source: &str) -> Result<Vec<FrfSet>, IoError> {
    read_frf_csv_with(bytes, source, CoherencePolicy::Check)
}

/// [`read_frf_csv`] with the `coh:` columns checked as `coherence` says:
/// `Clamp` accepts values a little outside [0, 1] (the caller clamps them
/// with [`clamp_coherence`](crate::io::clamp_coherence)); `Ignore` does
/// not read them at all (no channel gets a coherence).
pub fn read_frf_csv_with(
    bytes: &[u8],
    source: &str,
    coherence: CoherencePolicy,
) -> Result<Vec<FrfSet>, IoError> {
    let quantity = metadata(bytes, source)?;
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(bytes);
    let headers = rdr
        .headers()
        .map_err(|e| from_csv_error(source, &e))?
        .clone();
    let header_line = rdr.position().line().max(1) as usize;
    let mut cols = columns(&headers, source, header_line)?;
    if coherence == CoherencePolicy::Ignore {
        // Not even parsed: a cell that is not a number cannot stop the import.
        cols.channels.iter_mut().for_each(|c| c.4 = None);
    }
    let groups = read_positions(&mut rdr, &headers, &cols, source, coherence)?;
    frf_sets(groups, &cols, quantity, source)
}

/// The data rows grouped by position, in the order positions first appear;
/// each row's size is bounded before it is kept, its label, frequency and
/// coherences checked as it is read.
fn read_positions(
    rdr: &mut csv::Reader<&[u8]>,
    headers: &csv::StringRecord,
    cols: &Columns,
    source: &str,
    coherence: CoherencePolicy,
) -> Result<Vec<Rows>, IoError> {
    let mut groups: Vec<Rows> = Vec::new();
    let mut group_of: HashMap<u32, usize> = HashMap::new();
    let mut cells_read = 0f64;
    for rec in rdr.records() {
        let rec = rec.map_err(|e| from_csv_error(source, &e))?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        let cell = |i: usize| rec.get(i).unwrap_or("");
        // The cells kept grow with the rows read; bound them as they come.
        cells_read += cols.channels.len().max(1) as f64;
        IoError::check_memory(
            source,
            Place::Line(line),
            || format!("{cells_read} FRF cells read up to here"),
            cells_read * BYTES_PER_CSV_CELL,
        )?;
        let index = match cols.position {
            Some(i) => cell(i).parse::<u32>().map_err(|_| {
                IoError::not_numeric(
                    source,
                    Place::Line(line),
                    "position (0-based index)",
                    cell(i).as_bytes(),
                )
            })?,
            None => 0,
        };
        let label = cols.label.map(cell).unwrap_or_default();
        let g = match group_of.get(&index) {
            Some(&g) => g,
            None => {
                groups.push(Rows {
                    position: Position {
                        index,
                        label: label.to_string(),
                    },
                    first_line: line,
                    lines: Vec::new(),
                    freqs: Vec::new(),
                    cells: vec![Vec::new(); cols.channels.len()],
                    coh: vec![Vec::new(); cols.channels.len()],
                });
                group_of.insert(index, groups.len() - 1);
                groups.len() - 1
            }
        };
        let g = &mut groups[g];
        if g.position.label != label {
            return Err(csv_err(
                source,
                line,
                format!(
                    "position {index} is labelled {label:?} here but {:?} above",
                    g.position.label
                ),
            ));
        }
        let f = real_cell(source, line, "frequency_hz", cell(cols.frequency))?;
        check_frequency(f, g.freqs.last().copied()).map_err(|m| {
            IoError::implausible(
                source,
                Place::Line(line),
                format!("frequency_hz of position {index}: {m}"),
            )
        })?;
        g.freqs.push(f);
        g.lines.push(line);
        push_cells(g, &rec, headers, cols, (source, line), coherence)?;
    }
    Ok(groups)
}

/// Append record `rec`'s FRF and coherence cells (one per channel, `None`
/// when empty) to position `g`, checking each value (coherences as `policy`
/// accepts them); `(source, line)` locates errors.
fn push_cells(
    g: &mut Rows,
    rec: &csv::StringRecord,
    headers: &csv::StringRecord,
    cols: &Columns,
    (source, line): (&str, usize),
    policy: CoherencePolicy,
) -> Result<(), IoError> {
    let column = |i: usize| headers.get(i).unwrap_or("");
    let cell = |i: usize| rec.get(i).unwrap_or("");
    for (k, (name, _, re, im, coh)) in cols.channels.iter().enumerate() {
        let (re_text, im_text) = (cell(*re), cell(*im));
        let v = match (re_text.is_empty(), im_text.is_empty()) {
            (true, true) => None,
            (false, false) => Some(Complex64::new(
                real_cell(source, line, column(*re), re_text)?,
                real_cell(source, line, column(*im), im_text)?,
            )),
            _ => {
                return Err(csv_err(
                    source,
                    line,
                    format!("channel {name}: re and im must both be given"),
                ))
            }
        };
        g.cells[k].push(v);
        let c = match coh.map(|i| (i, cell(i))).filter(|(_, c)| !c.is_empty()) {
            Some((i, c)) => {
                let v = real_cell(source, line, column(i), c)?;
                check_coherence_with(v, policy).map_err(|m| {
                    IoError::implausible(source, Place::Line(line), format!("{}: {m}", column(i)))
                })?;
                Some(v)
            }
            None => None,
        };
        g.coh[k].push(c);
    }
    Ok(())
}

/// One [`FrfSet`] per position, with the channels that have values; a
/// position without any, a channel or coherence filled in some rows only,
/// and a table without rows are errors.
fn frf_sets(
    groups: Vec<Rows>,
    cols: &Columns,
    quantity: FrfQuantity,
    source: &str,
) -> Result<Vec<FrfSet>, IoError> {
    let mut sets = Vec::new();
    for g in groups {
        let mut channels = Vec::new();
        for (k, (name, (response, reference), ..)) in cols.channels.iter().enumerate() {
            let Some(values) = complete(&g.cells[k], &g, source, name)? else {
                continue;
            };
            let coherence = complete(&g.coh[k], &g, source, &format!("coherence of {name}"))?;
            let (response, reference) = (*response, *reference);
            channels.push(FrfChannel {
                response,
                reference,
                values,
                coherence,
            });
        }
        if channels.is_empty() {
            return Err(IoError::NoFrf {
                at: Location::new(source, Place::Line(g.first_line)),
                detail: format!("position {} has no filled re:/im: cells", g.position.index),
            });
        }
        sets.push(FrfSet {
            position: g.position,
            quantity,
            frequencies_hz: g.freqs,
            channels,
        });
    }
    if sets.is_empty() {
        return Err(IoError::NoFrf {
            at: Location::new(source, Place::File),
            detail: "the table has no data rows".into(),
        });
    }
    Ok(sets)
}

/// All cells given → the values; all empty → `None`; a mix is an error.
fn complete<T: Copy>(
    cells: &[Option<T>],
    g: &Rows,
    source: &str,
    name: &str,
) -> Result<Option<Vec<T>>, IoError> {
    if cells.iter().all(Option::is_none) {
        return Ok(None);
    }
    match cells.iter().position(Option::is_none) {
        Some(i) => Err(csv_err(
            source,
            g.lines[i],
            format!(
                "{name} is empty here but given in other rows of position {}",
                g.position.index
            ),
        )),
        None => Ok(Some(cells.iter().flatten().copied().collect())),
    }
}

/// Writes FRF sets as a CSV table. All sets must have one quantity.
pub fn write_frf_csv(sets: &[FrfSet]) -> Result<Vec<u8>, IoError> {
    let quantity = sets.first().map(|s| s.quantity).unwrap_or_default();
    if sets.iter().any(|s| s.quantity != quantity) {
        return Err(IoError::Unwritable {
            what:
                "FRF sets of different quantities into one CSV table; write one file per quantity"
                    .into(),
        });
    }
    let with_position = sets.len() > 1 || sets.iter().any(|s| s.position.index != 0);
    let with_label = sets.iter().any(|s| !s.position.label.is_empty());
    // Channels in first-seen order, with whether any set has a coherence.
    let mut names: Vec<(String, bool)> = Vec::new();
    let mut slot: HashMap<(Dof, Dof), usize> = HashMap::new();
    for s in sets {
        for c in &s.channels {
            match slot.get(&(c.response, c.reference)) {
                Some(&k) => names[k].1 |= c.coherence.is_some(),
                None => {
                    slot.insert((c.response, c.reference), names.len());
                    names.push((
                        format_channel(c.response, c.reference),
                        c.coherence.is_some(),
                    ));
                }
            }
        }
    }
    let mut header: Vec<String> = Vec::new();
    if with_position {
        header.push("position".into());
    }
    if with_label {
        header.push("position_label".into());
    }
    header.push("frequency_hz".into());
    for (n, coh) in &names {
        header.push(format!("re:{n}"));
        header.push(format!("im:{n}"));
        if *coh {
            header.push(format!("coh:{n}"));
        }
    }
    let mut out = format!("# quantity: {}\n", quantity_name(quantity)).into_bytes();
    let mut w = csv::Writer::from_writer(&mut out);
    let unwritable = |e: csv::Error| IoError::Unwritable {
        what: format!("CSV: {e}"),
    };
    w.write_record(&header).map_err(unwritable)?;
    for s in sets {
        // This set's channel in each column slot.
        let mut by_slot: Vec<Option<&FrfChannel>> = vec![None; names.len()];
        for c in &s.channels {
            if let Some(&k) = slot.get(&(c.response, c.reference)) {
                by_slot[k] = Some(c);
            }
        }
        for (i, f) in s.frequencies_hz.iter().enumerate() {
            let mut row: Vec<String> = Vec::with_capacity(header.len());
            if with_position {
                row.push(s.position.index.to_string());
            }
            if with_label {
                row.push(s.position.label.clone());
            }
            row.push(fmt_f64(*f));
            for ((_, has_coh), ch) in names.iter().zip(&by_slot) {
                let v = ch.and_then(|c| c.values.get(i));
                row.push(v.map(|v| fmt_f64(v.re)).unwrap_or_default());
                row.push(v.map(|v| fmt_f64(v.im)).unwrap_or_default());
                if *has_coh {
                    let c = ch.and_then(|c| c.coherence.as_ref()).and_then(|c| c.get(i));
                    row.push(c.map(|c| fmt_f64(*c)).unwrap_or_default());
                }
            }
            w.write_record(&row).map_err(unwritable)?;
        }
    }
    w.flush().map_err(|e| IoError::Unwritable {
        what: format!("CSV: {e}"),
    })?;
    drop(w);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::FrfQuantity;

    fn set(index: u32, label: &str, dofs: &[(u32, i8)], coherence: bool) -> FrfSet {
        let f: Vec<f64> = (0..5).map(|i| 0.1 + i as f64 / 3.0).collect();
        FrfSet {
            position: Position {
                index,
                label: label.into(),
            },
            quantity: FrfQuantity::Mobility,
            channels: dofs
                .iter()
                .map(|&(n, d)| FrfChannel {
                    response: Dof::new(n, d),
                    reference: Dof::new(1, -3),
                    values: f
                        .iter()
                        .map(|x| Complex64::new(x.sin() * 1e-9, -x.exp() * 1e7))
                        .collect(),
                    coherence: coherence.then(|| f.iter().map(|x| 1.0 - x / 10.0).collect()),
                })
                .collect(),
            frequencies_hz: f,
        }
    }

    #[test]
    fn round_trip_is_bitwise_with_positions_and_gaps() {
        let sets = vec![
            set(0, "wpt=0.25, \"front\"", &[(101, 1), (102, -6)], true),
            set(4, "", &[(102, -6), (7, 0)], false),
        ];
        let text = write_frf_csv(&sets).unwrap();
        let s = String::from_utf8(text.clone()).unwrap();
        assert!(
            s.starts_with(
                "# quantity: mobility\nposition,position_label,frequency_hz,re:101+X/1-Z,"
            ),
            "{s}"
        );
        let back = read_frf_csv(&text, "t.csv").unwrap();
        assert_eq!(back, sets);
        let bits = |s: &[FrfSet]| -> Vec<u64> {
            s.iter()
                .flat_map(|s| {
                    s.channels
                        .iter()
                        .flat_map(|c| c.values.iter().map(|v| v.im.to_bits()))
                })
                .collect()
        };
        assert_eq!(bits(&back), bits(&sets));
    }

    #[test]
    fn reads_a_hand_written_table() {
        let text =
            "# exported by hand\nim:5+Z/5+Z,frequency_hz,re:5+Z/5+Z\n0.5,10,1e-6\n-0.25,20,2e-6\n";
        let sets = read_frf_csv(text.as_bytes(), "hand.csv").unwrap();
        assert_eq!(sets.len(), 1);
        assert_eq!(sets[0].quantity, FrfQuantity::Receptance);
        assert_eq!(sets[0].frequencies_hz, vec![10.0, 20.0]);
        assert_eq!(sets[0].channels[0].values[1], Complex64::new(2e-6, -0.25));
        assert_eq!(sets[0].channels[0].response, Dof::new(5, 3));
    }

    fn err(text: &str) -> IoError {
        read_frf_csv(text.as_bytes(), "bad.csv").unwrap_err()
    }

    #[test]
    fn errors_name_line_and_problem() {
        let e = err("frequency_hz,re:1+X/1+X\n1,2\n");
        assert!(e.to_string().contains("no `im:1+X/1+X` partner"), "{e}");
        let e = err("# quantity: receptance\nfrequency_hz,re:1+X/1+X,im:1+X/1+X\n1,2,3\n2,x,3\n");
        assert_eq!(e.location().map(|l| l.place), Some(Place::Line(4)), "{e}");
        let e = err("frequency_hz,re:1+X/1+X,im:1+X/1+X\n2,2,3\n1,2,3\n");
        assert!(e.to_string().contains("does not increase"), "{e}");
        let e = err("frequency_hz,re:1+X/1+X,im:1+X/1+X\n1,2,3\n2,,\n");
        assert!(e.to_string().contains("empty here"), "{e}");
        assert!(matches!(
            err("frequency_hz,re:1+X/1+X,im:1+X/1+X\n1,NaN,3\n"),
            IoError::NonFinite { .. }
        ));
        assert!(matches!(
            err("frequency_hz,re:1+X/1+X,im:1+X/1+X\n"),
            IoError::NoFrf { .. }
        ));
        let e = err("freq,re:1+X/1+X,im:1+X/1+X\n1,2,3\n");
        assert!(e.to_string().contains("frequency_hz"), "{e}");
        let e = err("frequency_hz,re:1+X/1+X,im:1+X/1+X\n1,2\n");
        assert!(e.to_string().contains("bad.csv, line 2"), "{e}");
    }

    #[test]
    fn coherence_policies_check_clamp_and_ignore() {
        use crate::io::{clamp_coherence, CoherencePolicy as Policy};
        let table = |c: &str| {
            format!("frequency_hz,re:1+X/1+X,im:1+X/1+X,coh:1+X/1+X\n1,2,3,0.5\n2,2,3,{c}\n")
        };
        let read = |c: &str, p| read_frf_csv_with(table(c).as_bytes(), "c.csv", p);
        let e = read("1.2", Policy::Check).unwrap_err();
        assert_eq!(e.location().map(|l| l.place), Some(Place::Line(3)), "{e}");
        assert!(e.to_string().contains("`coherence: clamp`"), "{e}");
        for (c, want) in [("1.2", 1.0), ("-0.005", 0.0), ("2", 1.0)] {
            let mut sets = read(c, Policy::Clamp).unwrap();
            let clamps = clamp_coherence(&mut sets).unwrap();
            assert_eq!((clamps.lines, clamps.band_hz), (1, [2.0, 2.0]));
            let gamma = sets[0].channels[0].coherence.as_deref().unwrap();
            assert_eq!(gamma, &[0.5, want][..], "{c}");
        }
        for c in ["2.5", "-0.5", "NaN", "inf"] {
            let e = read(c, Policy::Clamp).unwrap_err();
            assert_eq!(
                e.location().map(|l| l.place),
                Some(Place::Line(3)),
                "{c}: {e}"
            );
        }
        // Not even parsed: no coherence, whatever the cells hold.
        for c in ["7", "NaN", "n/a"] {
            let sets = read(c, Policy::Ignore).unwrap();
            assert!(sets[0].channels[0].coherence.is_none(), "{c}");
        }
        assert!(read("1", Policy::Ignore).unwrap()[0].channels[0]
            .coherence
            .is_none());
    }
}
