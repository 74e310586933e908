//! UFF dataset 82, "tracelines": the wire-frame a test geometry is drawn
//! with (I-DEAS universal file definition, as pyuff's `dataset_82.py`
//! reads it).
//!
//! | record | format | contents |
//! |---|---|---|
//! | 1 | 3I10 | trace line number, number of nodes, colour |
//! | 2 | 80A1 | identification line |
//! | 3 | 8I10 | the nodes in drawing order; 0 lifts the pen (a break) |

use super::text::{self, Cursor};
use crate::io::error::IoError;

/// One trace line: node ids in order, 0 = break.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceLine {
    pub number: i64,
    pub color: i64,
    pub id: String,
    pub nodes: Vec<i64>,
}

impl TraceLine {
    /// The segments (pairs of consecutive nodes, breaks skipped).
    pub fn segments(&self) -> Vec<(i64, i64)> {
        self.nodes
            .windows(2)
            .filter(|w| w[0] != 0 && w[1] != 0)
            .map(|w| (w[0], w[1]))
            .collect()
    }
}

/// Largest node count accepted (the definition allows 250; some writers
/// exceed it).
const MAX_NODES: usize = 100_000;

/// Parses records 1–3 and the closing `-1`, the cursor after the `82` line.
pub(crate) fn parse(cur: &mut Cursor<'_>) -> Result<TraceLine, IoError> {
    let src = cur.source;
    let r1 = cur.expect_record("dataset 82 record 1 (trace line number, nodes, colour)")?;
    let f: Vec<i64> = text::tokens(r1.text)
        .map(|t| std::str::from_utf8(t).ok().and_then(|s| s.parse().ok()))
        .collect::<Option<Vec<i64>>>()
        .filter(|v| v.len() == 3)
        .ok_or_else(|| {
            IoError::record_length(src, r1.place(), "dataset 82 record 1 needs 3 integers")
        })?;
    let n = usize::try_from(f[1])
        .ok()
        .filter(|&n| n <= MAX_NODES)
        .ok_or_else(|| {
            IoError::invalid(
                src,
                r1.place(),
                "dataset 82 number of nodes",
                f[1],
                "0 to 100000",
            )
        })?;
    let id = String::from_utf8_lossy(cur.expect_record("dataset 82 record 2 (ID line)")?.text)
        .trim_end()
        .to_string();
    // Writers pad the last line of record 3 with zeros (8 per line).
    let mut nodes = Vec::with_capacity(n);
    let mut extra = Vec::new();
    while nodes.len() < n {
        let line = cur.expect_record("dataset 82 record 3 (nodes)")?;
        for t in text::tokens(line.text) {
            let v: i64 = std::str::from_utf8(t)
                .ok()
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| IoError::not_numeric(src, line.place(), "trace line node", t))?;
            if nodes.len() < n {
                nodes.push(v);
            } else {
                extra.push((v, line.place()));
            }
        }
    }
    if let Some((_, place)) = extra.iter().find(|(v, _)| *v != 0) {
        return Err(IoError::record_length(
            src,
            *place,
            format!(
                "dataset 82 declares {n} nodes but lists {}",
                n + extra.len()
            ),
        ));
    }
    cur.expect_delimiter("82")?;
    Ok(TraceLine {
        number: f[0],
        color: f[2],
        id,
        nodes,
    })
}

#[cfg(test)]
mod tests {
    use crate::io::uff::{read_uff, UffDataset};

    #[test]
    fn trace_lines_read_with_breaks() {
        let text = "    -1\n    82\n         1        11         8\nframe\n         1         2         3         4         1         0         5         6\n         7         8         5\n    -1\n";
        let f = read_uff(text.as_bytes(), "t.uff").unwrap();
        let UffDataset::TraceLine(t) = &f.blocks[0].dataset else {
            panic!("{:?}", f.blocks)
        };
        assert_eq!(t.nodes.len(), 11);
        assert_eq!(t.segments().len(), 8, "the 0 breaks the line");
        assert_eq!(t.id, "frame");
        let padded = "    -1\n    82\n         1         3         8\nx\n         1         2         3         0         0\n    -1\n";
        assert!(read_uff(padded.as_bytes(), "t.uff").is_ok());
        let bad = "    -1\n    82\n         1         3         8\nx\n         1         2         3         4\n    -1\n";
        assert!(read_uff(bad.as_bytes(), "t.uff").is_err());
    }
}
