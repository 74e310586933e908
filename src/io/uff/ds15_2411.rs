//! Node coordinates from UFF datasets 15 ("nodes", single precision) and 2411
//! ("nodes - double precision"), for geometry in reports.
//!
//! - 15: one line per node, `4I10,3E13.5`: node label, definition coordinate
//!   system, displacement coordinate system, colour, x, y, z.
//! - 2411: two lines per node, `4I10` (label, export coordinate system,
//!   displacement coordinate system, colour) then `3D25.16` (x, y, z).
//!
//! Coordinates are returned as written, in the node's definition coordinate
//! system (dataset 18/2420 transforms are not applied).

use super::text::{self, Cursor};
use crate::io::error::IoError;

/// One node of a dataset 15 or 2411.
#[derive(Clone, Debug, PartialEq)]
pub struct UffNode {
    pub id: i64,
    pub coordinate_system: i64,
    pub displacement_system: i64,
    pub color: i64,
    pub xyz: [f64; 3],
}

/// The nodes of one dataset, with its number (15 or 2411).
#[derive(Clone, Debug, PartialEq)]
pub struct NodeTable {
    pub dataset: u32,
    pub nodes: Vec<UffNode>,
}

fn ints4(cur: &Cursor<'_>, line: &text::Line<'_>, toks: &[&[u8]]) -> Result<[i64; 4], IoError> {
    let mut out = [0i64; 4];
    for (o, t) in out.iter_mut().zip(toks) {
        *o = std::str::from_utf8(t)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| {
                IoError::not_numeric(cur.source, line.place(), "node label/system/colour", t)
            })?;
    }
    Ok(out)
}

/// Parses dataset 15 lines up to and including the closing `-1`.
pub(crate) fn parse15(cur: &mut Cursor<'_>) -> Result<NodeTable, IoError> {
    let mut nodes = Vec::new();
    loop {
        let line = cur.expect_line("a dataset 15 node line or the closing `-1`")?;
        if line.is_delimiter() {
            break;
        }
        if line.trimmed().is_empty() {
            continue;
        }
        let toks: Vec<&[u8]> = text::tokens(line.text).collect();
        if toks.len() != 7 {
            return Err(IoError::record_length(
                cur.source,
                line.place(),
                format!(
                    "a dataset 15 node line has 7 fields (4I10,3E13.5), found {}",
                    toks.len()
                ),
            ));
        }
        let [id, cs, ds, color] = ints4(cur, &line, &toks[..4])?;
        let mut xyz = [0.0; 3];
        for (x, t) in xyz.iter_mut().zip(&toks[4..]) {
            *x = text::parse_f64(t)
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    IoError::not_numeric(cur.source, line.place(), "node coordinate", t)
                })?;
        }
        nodes.push(UffNode {
            id,
            coordinate_system: cs,
            displacement_system: ds,
            color,
            xyz,
        });
    }
    Ok(NodeTable { dataset: 15, nodes })
}

/// Parses dataset 2411 record pairs up to and including the closing `-1`.
pub(crate) fn parse2411(cur: &mut Cursor<'_>) -> Result<NodeTable, IoError> {
    let mut nodes = Vec::new();
    loop {
        let line = cur.expect_line("a dataset 2411 node record or the closing `-1`")?;
        if line.is_delimiter() {
            break;
        }
        if line.trimmed().is_empty() {
            continue;
        }
        let toks: Vec<&[u8]> = text::tokens(line.text).collect();
        if toks.len() != 4 {
            return Err(IoError::record_length(
                cur.source,
                line.place(),
                format!(
                    "dataset 2411 record 1 has 4 integers (4I10), found {} fields",
                    toks.len()
                ),
            ));
        }
        let [id, cs, ds, color] = ints4(cur, &line, &toks)?;
        let mut xyz = Vec::with_capacity(3);
        text::read_numbers(
            cur,
            3,
            false,
            "dataset 2411 record 2 (coordinates)",
            &mut xyz,
        )?;
        nodes.push(UffNode {
            id,
            coordinate_system: cs,
            displacement_system: ds,
            color,
            xyz: [xyz[0], xyz[1], xyz[2]],
        });
    }
    Ok(NodeTable {
        dataset: 2411,
        nodes,
    })
}
