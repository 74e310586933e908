//! Helpers shared by the CSV readers and writers: header lookup, cell
//! parsing with line numbers, metadata lines and exact number text.

use crate::frf::FrfQuantity;
use crate::io::error::{IoError, Location, Place};

/// Shortest text that reads back to the same `f64`, without 300-digit
/// expansions for tiny or huge values.
pub(crate) fn fmt_f64(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

pub(crate) fn quantity_name(q: FrfQuantity) -> &'static str {
    q.name()
}

pub(crate) fn csv_err(source: &str, line: usize, what: impl Into<String>) -> IoError {
    IoError::Csv {
        at: Location::new(source, Place::Line(line)),
        what: what.into(),
    }
}

pub(crate) fn from_csv_error(source: &str, e: &csv::Error) -> IoError {
    let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
    let place = if line > 0 {
        Place::Line(line)
    } else {
        Place::File
    };
    IoError::Csv {
        at: Location::new(source, place),
        what: format!("malformed CSV: {e}"),
    }
}

/// Parses a finite number cell.
pub(crate) fn real_cell(
    source: &str,
    line: usize,
    column: &str,
    cell: &str,
) -> Result<f64, IoError> {
    let v: f64 = cell
        .parse()
        .map_err(|_| IoError::not_numeric(source, Place::Line(line), column, cell.as_bytes()))?;
    if !v.is_finite() {
        return Err(IoError::NonFinite {
            at: Location::new(source, Place::Line(line)),
            field: column.to_string(),
            value: v,
        });
    }
    Ok(v)
}

/// Reads the leading `# key: value` lines.
pub(crate) fn metadata(bytes: &[u8], source: &str) -> Result<FrfQuantity, IoError> {
    let mut quantity = FrfQuantity::Receptance;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let Some(rest) = line.trim_ascii().strip_prefix(b"#") else {
            break;
        };
        let text = String::from_utf8_lossy(rest);
        if let Some((key, value)) = text.split_once(':') {
            if key.trim().eq_ignore_ascii_case("quantity") {
                quantity = match value.trim().to_ascii_lowercase().as_str() {
                    "receptance" => FrfQuantity::Receptance,
                    "mobility" => FrfQuantity::Mobility,
                    "accelerance" | "inertance" => FrfQuantity::Accelerance,
                    other => {
                        return Err(csv_err(
                            source,
                            i + 1,
                            format!(
                            "unknown quantity {other:?}; use receptance, mobility or accelerance"
                        ),
                        ))
                    }
                };
            }
        }
    }
    Ok(quantity)
}

/// A CSV file's header → column lookup, rejecting unknown columns.
pub(crate) struct Table {
    headers: Vec<String>,
}

impl Table {
    pub(crate) fn open<'a>(
        bytes: &'a [u8],
        source: &str,
        known: &[&str],
        required: &[&str],
    ) -> Result<(Self, csv::Reader<&'a [u8]>), IoError> {
        let mut rdr = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .from_reader(bytes);
        let headers: Vec<String> = rdr
            .headers()
            .map_err(|e| from_csv_error(source, &e))?
            .iter()
            .map(str::to_string)
            .collect();
        let header_line = rdr.position().line().max(1) as usize;
        for h in &headers {
            if !known.contains(&h.as_str()) {
                return Err(csv_err(
                    source,
                    header_line,
                    format!("unknown column {h:?}; expected {}", known.join(", ")),
                ));
            }
        }
        for r in required {
            if !headers.iter().any(|h| h == r) {
                return Err(csv_err(
                    source,
                    header_line,
                    format!("missing column `{r}`"),
                ));
            }
        }
        Ok((Table { headers }, rdr))
    }

    pub(crate) fn col(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h == name)
    }
}

pub(crate) fn int_cell<T: std::str::FromStr>(
    source: &str,
    line: usize,
    column: &str,
    cell: &str,
) -> Result<T, IoError> {
    cell.parse()
        .map_err(|_| IoError::not_numeric(source, Place::Line(line), column, cell.as_bytes()))
}
