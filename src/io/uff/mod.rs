//! Universal File Format (UFF, I-DEAS "universal file"): splitting a file into
//! datasets, reading the ones this module understands (58/58b functions,
//! 55 data at nodes, 15/2411 nodes) and skipping the rest with one warning per
//! dataset number.
//!
//! A universal file is a sequence of datasets, each framed by lines holding
//! `-1` in columns 1–6; the first line inside is the dataset number
//! (`    58`, or `    58b …` for the binary variant). Readers work on bytes:
//! LF or CRLF line ends, non-UTF-8 text in ID lines (read lossily), stray
//! blank lines between datasets. Nothing is printed; warnings are returned.

pub mod artifact;
pub mod ds15_2411;
pub mod ds55;
pub mod ds58;
pub mod ds58_binary;
mod ds58_records;
pub mod ds82;
pub mod frf_sets;
pub mod modal_models;
pub(crate) mod text;
pub mod units;

use crate::io::error::{IoError, Place};
use crate::io::validity::CoherencePolicy;
use ds15_2411::NodeTable;
use ds55::Uff55;
use ds58::{NumberText, Uff58, Uff58Format};
use std::fmt;
use text::Cursor;

/// A dataset this reader understands.
#[derive(Clone, Debug, PartialEq)]
pub enum UffDataset {
    /// Dataset 58 / 58b, function at nodal DOF.
    Function(Box<Uff58>),
    /// Dataset 55, data at nodes (modes).
    DataAtNodes(Box<Uff55>),
    /// Dataset 15 or 2411, node coordinates.
    Nodes(NodeTable),
    /// Dataset 82, a trace line of the wire-frame.
    TraceLine(ds82::TraceLine),
    /// Dataset 164, the file's unit system.
    Units(units::Units164),
}

/// A dataset and where it starts (its opening `-1` line).
#[derive(Clone, Debug, PartialEq)]
pub struct UffBlock {
    pub at: Place,
    /// The line of the dataset's record 1 (the line after the dataset
    /// number): record r of the text header is line `record1 + r − 1`.
    pub record1: Place,
    pub dataset: UffDataset,
}

impl UffBlock {
    /// Where record `r` (1-based) of the dataset's text header is, so an
    /// error about a field of record 9 names record 9's line, not the
    /// dataset's first one. Records 1–11 of 58/58b and 1–8 of 55 are one
    /// line each.
    pub fn record(&self, r: usize) -> Place {
        match self.record1 {
            Place::Line(l) => Place::Line(l + r.saturating_sub(1)),
            other => other,
        }
    }
}

/// Something the reader or a conversion left out, reported once per kind.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum UffWarning {
    /// Datasets of an unsupported number were skipped.
    SkippedDatasets {
        dataset: u32,
        count: usize,
        first: Place,
    },
    /// Functions (dataset 58) of a type the FRF conversion does not use.
    UnusedFunctions { function_type: i32, count: usize },
    /// A coherence function without an FRF of the same DOFs and position.
    UnmatchedCoherence { channel: String, position: u32 },
    /// Datasets 58b whose header byte count disagrees with record 7 while the
    /// data up to the `-1` delimiter match record 7 (the writer's mistake,
    /// e.g. pyuff's points × 8 for complex doubles); read by record 7.
    HeaderByteCount {
        declared: usize,
        needed: usize,
        count: usize,
        first: Place,
    },
    /// Datasets 55 that are not modes (analysis type other than 2, 3, 7)
    /// or have no mode-shape layout (data characteristic other than 1, 2, 3).
    UnusedDataAtNodes {
        analysis_type: i64,
        data_characteristic: i64,
        count: usize,
    },
}

impl fmt::Display for UffWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UffWarning::SkippedDatasets { dataset, count, first } => write!(
                f,
                "skipped {count} dataset(s) {dataset} (first at {first}): not read by modalflow"
            ),
            UffWarning::UnusedFunctions { function_type, count } => write!(
                f,
                "ignored {count} function(s) of type {function_type}: only FRFs (4) and coherences (6) are imported"
            ),
            UffWarning::UnmatchedCoherence { channel, position } => write!(
                f,
                "coherence {channel} in position {position} has no FRF of the same DOFs; ignored"
            ),
            UffWarning::HeaderByteCount { declared, needed, count, first } => write!(
                f,
                "{count} dataset(s) 58b declare a wrong data byte count in the header (first at {first}: \
                 {declared} bytes, record 7 and the `-1` delimiter say {needed}); read by record 7 — \
                 the writer counts points × 8 regardless of the layout (a known pyuff mistake)"
            ),
            UffWarning::UnusedDataAtNodes { analysis_type, data_characteristic, count } => write!(
                f,
                "ignored {count} dataset(s) 55 with analysis type {analysis_type} and data \
                 characteristic {data_characteristic}: not mode shapes"
            ),
        }
    }
}

/// The datasets of one universal file.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct UffFile {
    pub blocks: Vec<UffBlock>,
    pub warnings: Vec<UffWarning>,
}

impl UffFile {
    /// All datasets 58 in file order.
    pub fn functions(&self) -> impl Iterator<Item = &Uff58> {
        self.blocks.iter().filter_map(|b| match &b.dataset {
            UffDataset::Function(f) => Some(f.as_ref()),
            _ => None,
        })
    }

    /// All datasets 55 in file order.
    pub fn data_at_nodes(&self) -> impl Iterator<Item = &Uff55> {
        self.blocks.iter().filter_map(|b| match &b.dataset {
            UffDataset::DataAtNodes(d) => Some(d.as_ref()),
            _ => None,
        })
    }

    /// The unit system of the first dataset 164, if any.
    pub fn units(&self) -> Option<&units::Units164> {
        self.blocks.iter().find_map(|b| match &b.dataset {
            UffDataset::Units(u) => Some(u),
            _ => None,
        })
    }

    /// Segments (node pairs) of every dataset 82 trace line.
    pub fn trace_segments(&self) -> Vec<(i64, i64)> {
        self.blocks
            .iter()
            .filter_map(|b| match &b.dataset {
                UffDataset::TraceLine(t) => Some(t.segments()),
                _ => None,
            })
            .flatten()
            .collect()
    }

    /// Node id → (x, y, z) from every dataset 15/2411 (later datasets win).
    pub fn node_coordinates(&self) -> std::collections::BTreeMap<i64, [f64; 3]> {
        let mut map = std::collections::BTreeMap::new();
        for b in &self.blocks {
            if let UffDataset::Nodes(t) = &b.dataset {
                for n in &t.nodes {
                    map.insert(n.id, n.xyz);
                }
            }
        }
        map
    }
}

/// Reads every dataset of a universal file. `source` names the bytes in
/// errors (pass the file name). Unsupported datasets are skipped, with one
/// [`UffWarning::SkippedDatasets`] per dataset number. Coherences outside
/// [0, 1] are errors ([`read_uff_with`] accepts more).
pub fn read_uff(bytes: &[u8], source: &str) -> Result<UffFile, IoError> {
    read_uff_with(bytes, source, CoherencePolicy::Check)
}

/// [`read_uff`] with the coherences (datasets 58 of function type 6)
/// checked as `coherence` says: the import's `coherence: clamp` accepts
/// values a little outside [0, 1] (it clamps them on the FRF sets), and
/// `ignore` does not check them (it drops them).
pub fn read_uff_with(
    bytes: &[u8],
    source: &str,
    coherence: CoherencePolicy,
) -> Result<UffFile, IoError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut cur = Cursor::new(bytes, source);
    let mut file = UffFile::default();
    loop {
        cur.skip_blank_lines();
        let Some(open) = cur.next_line() else { break };
        if !open.is_delimiter() {
            return Err(IoError::invalid(
                source,
                open.place(),
                "dataset delimiter",
                format!(
                    "{:?}",
                    String::from_utf8_lossy(&open.text[..open.text.len().min(40)])
                ),
                "expected the `    -1` line that starts a dataset; the previous dataset holds \
                 more lines than its header declares, or this is not a universal file",
            ));
        }
        let mut number_line = cur.expect_line("a dataset number after `-1`")?;
        while number_line.is_delimiter() {
            number_line = cur.expect_line("a dataset number after `-1`")?;
        }
        let t = number_line.text.trim_ascii_start();
        let digits = t.iter().take_while(|b| b.is_ascii_digit()).count();
        let number: u32 = std::str::from_utf8(&t[..digits])
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| {
                IoError::not_numeric(source, number_line.place(), "dataset number", t)
            })?;
        let binary = t.get(digits).is_some_and(|b| b.eq_ignore_ascii_case(&b'b'));
        let record1 = Place::Line(number_line.number + 1);
        let after_b = t.get(digits + 1..).unwrap_or(&[]);
        let dataset = match (number, binary) {
            (58, false) => {
                UffDataset::Function(Box::new(ds58::parse(&mut cur, None, coherence)?.0))
            }
            (58, true) => {
                let h = ds58_binary::parse_binary_header(source, &number_line, after_b)?;
                let (d, mismatch) = ds58::parse(&mut cur, Some(h), coherence)?;
                if let Some(m) = mismatch {
                    note_byte_count(&mut file.warnings, m);
                }
                UffDataset::Function(Box::new(d))
            }
            (55, false) => UffDataset::DataAtNodes(Box::new(ds55::parse(&mut cur)?)),
            (15, false) => UffDataset::Nodes(ds15_2411::parse15(&mut cur)?),
            (2411, false) => UffDataset::Nodes(ds15_2411::parse2411(&mut cur)?),
            (164, false) => UffDataset::Units(units::parse164(&mut cur)?),
            (82, false) => UffDataset::TraceLine(ds82::parse(&mut cur)?),
            _ => {
                skip_dataset(&mut cur, binary.then_some(after_b))?;
                note_skipped(&mut file.warnings, number, open.place());
                continue;
            }
        };
        file.blocks.push(UffBlock {
            at: open.place(),
            record1,
            dataset,
        });
    }
    Ok(file)
}

fn note_byte_count(warnings: &mut Vec<UffWarning>, m: ds58_binary::ByteCountMismatch) {
    for w in warnings.iter_mut() {
        if let UffWarning::HeaderByteCount { count, .. } = w {
            *count += 1;
            return;
        }
    }
    warnings.push(UffWarning::HeaderByteCount {
        declared: m.declared,
        needed: m.needed,
        count: 1,
        first: m.place,
    });
}

fn note_skipped(warnings: &mut Vec<UffWarning>, number: u32, at: Place) {
    for w in warnings.iter_mut() {
        if let UffWarning::SkippedDatasets { dataset, count, .. } = w {
            if *dataset == number {
                *count += 1;
                return;
            }
        }
    }
    warnings.push(UffWarning::SkippedDatasets {
        dataset: number,
        count: 1,
        first: at,
    });
}

/// Skips an unsupported dataset: text up to its `-1`, or for a binary one
/// (`NNNNb` line with ASCII line and byte counts) the declared lines and bytes.
fn skip_dataset(cur: &mut Cursor<'_>, binary_fields: Option<&[u8]>) -> Result<(), IoError> {
    if let Some(fields) = binary_fields {
        let nums: Vec<usize> = fields
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                std::str::from_utf8(t)
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(0)
            })
            .collect();
        let (lines, n_bytes) = (
            nums.get(2).copied().unwrap_or(0),
            nums.get(3).copied().unwrap_or(0),
        );
        for _ in 0..lines {
            cur.expect_line("a header line of a binary dataset")?;
        }
        let at = cur.offset();
        cur.take_bytes(n_bytes).ok_or_else(|| {
            IoError::truncated(
                cur.source,
                Place::Byte(at),
                format!("binary block of {n_bytes} bytes"),
            )
        })?;
        return cur.expect_delimiter("(binary, skipped)");
    }
    loop {
        let line = cur.expect_line("the `-1` line that ends a skipped dataset")?;
        if line.is_delimiter() {
            return Ok(());
        }
    }
}

/// Writes datasets 58 (ASCII or 58b as `format` says).
pub fn write_uff58(datasets: &[Uff58], format: &Uff58Format) -> Vec<u8> {
    let mut out = Vec::new();
    for d in datasets {
        ds58::write(&mut out, d, format);
    }
    out
}

/// Writes datasets 55 (always ASCII; 55 has no binary variant).
pub fn write_uff55(datasets: &[Uff55], digits: NumberText) -> Vec<u8> {
    let mut out = Vec::new();
    for d in datasets {
        ds55::write(&mut out, d, digits);
    }
    out
}

#[cfg(test)]
mod coherence_tests;
#[cfg(test)]
mod tests;
