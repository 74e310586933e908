//! The updated model file: the user's model file with each identified
//! parameter's `value` replaced by its identified value — everything else
//! (bounds, bodies, comments, layout) exactly as written — and a comment
//! line above each parameter saying where its value came from: the start
//! value, the identified value and its change, and the confidence where the
//! data determine it (relative standard error and 95 % interval), or why
//! not. The file is ready for another modalflow run (a `synthesize` or
//! `identify` stage's `model` param) or for the user's FE tool.
//!
//! The values are edited in the text, found by their source positions in
//! the YAML event stream (yaml-rust2), so flow (`- {name: k, value: 2e6}`)
//! and block items both work; each new value is written as the shortest
//! decimal that reads back as the same `f64` (Rust's `{:e}`), so the
//! updated model reproduces the identified one bit for bit.

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::{Marker, TScalarStyle};

/// What became of one parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterUpdate {
    pub name: String,
    pub initial: f64,
    pub identified: f64,
    /// Moved by the identification (else it kept its start value).
    pub moved: bool,
    /// Determined by the data (`None`: not analysed).
    pub identifiable: Option<bool>,
    /// Relative standard error (of ln p).
    pub std_error: Option<f64>,
    /// 95 % interval.
    pub interval: Option<(f64, f64)>,
}

impl ParameterUpdate {
    /// The comment line written above the parameter (without `# `).
    pub fn comment(&self) -> String {
        let sig = |v: f64| crate::numbers::sig(v, 6);
        let change = if self.initial != 0.0 {
            format!(
                " ({:+.2} %)",
                100.0 * (self.identified / self.initial - 1.0)
            )
        } else {
            String::new()
        };
        let confidence = match (self.moved, self.identifiable, self.std_error, self.interval) {
            (false, _, _, _) => "not identified: kept its start value".to_string(),
            (true, Some(true), Some(se), Some((lo, hi))) => format!(
                "standard error {} %, 95 % interval [{}, {}]",
                crate::numbers::sig(100.0 * se, 3),
                sig(lo),
                sig(hi)
            ),
            (true, Some(false), _, _) => {
                "not identifiable from the data: one of many values that fit as well".into()
            }
            _ => "confidence not known".into(),
        };
        format!(
            "{}: initial {}, identified {}{change}; {confidence}",
            self.name,
            sig(self.initial),
            sig(self.identified)
        )
    }
}

/// Where one parameter item sits in the text (char indices).
#[derive(Debug, Default)]
struct Item {
    name: Option<String>,
    /// Start of the item's mapping (its line gets the comment above it).
    start: usize,
    /// The `value` scalar: start, its source length and whether plain.
    value: Option<(usize, usize, bool)>,
}

/// Collects the items of the top-level `parameters` sequence.
#[derive(Default)]
struct Collector {
    /// Container depth: 1 = the top mapping.
    depth: usize,
    /// Within the top mapping: the last key seen at depth 1.
    top_key: Option<String>,
    in_parameters: bool,
    /// Key of the current item's mapping awaiting its value.
    item_key: Option<String>,
    expect_key: bool,
    items: Vec<Item>,
}

impl MarkedEventReceiver for Collector {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        match ev {
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                let seq = matches!(ev, Event::SequenceStart(..));
                if self.depth == 1 && seq && self.top_key.as_deref() == Some("parameters") {
                    self.in_parameters = true;
                } else if self.in_parameters && self.depth == 2 && !seq {
                    self.items.push(Item {
                        start: mark.index(),
                        ..Item::default()
                    });
                    self.expect_key = true;
                }
                if self.depth == 1 {
                    self.top_key = None;
                }
                self.depth += 1;
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.depth = self.depth.saturating_sub(1);
                if self.depth == 1 {
                    self.in_parameters = false;
                    self.top_key = None;
                }
            }
            Event::Scalar(text, style, ..) => {
                if self.depth == 1 {
                    self.top_key = match self.top_key {
                        None => Some(text),
                        Some(_) => None,
                    };
                } else if self.in_parameters && self.depth == 3 {
                    if self.expect_key {
                        self.item_key = Some(text);
                    } else if let Some(item) = self.items.last_mut() {
                        let len = text.chars().count();
                        match self.item_key.as_deref() {
                            Some("name") => item.name = Some(text),
                            Some("value") => {
                                let plain = style == TScalarStyle::Plain;
                                let quoted = if plain { 0 } else { 2 };
                                item.value = Some((mark.index(), len + quoted, plain));
                            }
                            _ => {}
                        }
                    }
                    self.expect_key = !self.expect_key;
                }
            }
            _ => {}
        }
    }
}

/// The model file `text` with the updates applied (module docs), headed by
/// `header` lines (as comments). Errors name the parameter that cannot be
/// updated: missing from the file, or its value not a plain number.
pub fn updated_model_file(
    text: &str,
    updates: &[ParameterUpdate],
    header: &[String],
) -> Result<String, String> {
    let mut c = Collector::default();
    Parser::new_from_str(text)
        .load(&mut c, false)
        .map_err(|e| format!("the model file is not valid YAML: {e}"))?;
    // Char index → byte offset.
    let bytes: Vec<usize> = text
        .char_indices()
        .map(|(b, _)| b)
        .chain([text.len()])
        .collect();
    let byte = |i: usize| bytes.get(i).copied().unwrap_or(text.len());
    // Edits as (byte offset, bytes removed, text inserted), applied from
    // the end so earlier offsets stay valid.
    let mut edits: Vec<(usize, usize, String)> = Vec::new();
    for u in updates {
        let item = c
            .items
            .iter()
            .find(|i| i.name.as_deref() == Some(u.name.as_str()))
            .ok_or_else(|| format!("parameter `{}` is not in the model file", u.name))?;
        let (at, len, plain) = item
            .value
            .ok_or_else(|| format!("parameter `{}` has no `value` in the model file", u.name))?;
        if !plain {
            return Err(format!(
                "parameter `{}`: its value is quoted; write it as a plain number",
                u.name
            ));
        }
        let (from, to) = (byte(at), byte(at + len));
        edits.push((from, to - from, format!("{:e}", u.identified)));
        let line_start = text[..byte(item.start)].rfind('\n').map_or(0, |i| i + 1);
        let indent: String = text[line_start..]
            .chars()
            .take_while(|c| *c == ' ' || *c == '\t')
            .collect();
        edits.push((line_start, 0, format!("{indent}# {}\n", u.comment())));
    }
    edits.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.cmp(&a.1)));
    let mut out = text.to_string();
    for (at, remove, insert) in edits {
        out.replace_range(at..at + remove, &insert);
    }
    let head: String = header.iter().map(|h| format!("# {h}\n")).collect();
    Ok(head + &out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn update(name: &str, initial: f64, identified: f64) -> ParameterUpdate {
        ParameterUpdate {
            name: name.into(),
            initial,
            identified,
            moved: true,
            identifiable: Some(true),
            std_error: Some(0.012),
            interval: Some((identified * 0.98, identified * 1.02)),
        }
    }

    #[test]
    fn values_change_in_place_and_everything_else_stays() {
        let text = "# my bench\nparameters:\n  - {name: k1.k_x,  value: 2.0e6, lower: 5.0e5, upper: 8.0e6, scale: log, kind: stiffness}\n  - name: c1\n    value: 40.0   # N·s/m\n    lower: 10\n    upper: 160\n    scale: log\n    kind: damping\nbodies: []\n";
        let third = 2.0e6 / 3.0;
        let out = updated_model_file(
            text,
            &[update("k1.k_x", 2.0e6, third), update("c1", 40.0, 38.5)],
            &["updated by a test".into()],
        )
        .unwrap();
        assert!(
            out.starts_with("# updated by a test\n# my bench\n"),
            "{out}"
        );
        assert!(
            out.contains(&format!("value: {third:e}, lower: 5.0e5")),
            "{out}"
        );
        assert!(out.contains("    value: 3.85e1   # N·s/m\n"), "{out}");
        assert!(
            out.contains(
                "  # k1.k_x: initial 2e6, identified 6.66667e5 (-66.67 %); standard error 1.2 %"
            ),
            "{out}"
        );
        assert!(
            out.contains("  # c1: initial 40, identified 38.5 (-3.75 %)"),
            "{out}"
        );
        // The written value reads back as the same double.
        let v: serde_yaml_ng::Value = serde_yaml_ng::from_str(&out).unwrap();
        assert_eq!(v["parameters"][0]["value"].as_f64(), Some(third));
        assert_eq!(v["parameters"][1]["upper"].as_f64(), Some(160.0));
        assert!(updated_model_file(text, &[update("k9", 1.0, 2.0)], &[])
            .unwrap_err()
            .contains("k9"));
        let quoted = "parameters:\n  - {name: k, value: \"2\"}\n";
        assert!(updated_model_file(quoted, &[update("k", 2.0, 3.0)], &[])
            .unwrap_err()
            .contains("quoted"));
    }
}
