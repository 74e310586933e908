//! The pipeline file schema, as serde reads it.
//!
//! Only the shape is checked here (`deny_unknown_fields`, types); meaning —
//! kinds, params, references, cycles — is checked by [`super::plan`], which
//! has the [`super::span::SpanIndex`] to point at the offending token.

use super::executor::ExecutorSpec;
use indexmap::IndexMap;
use serde::Deserialize;
use serde_yaml_ng::{Mapping, Value};

/// A whole pipeline file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    /// Results go to `results/<name>/`; also names the pipeline's last-run
    /// record in the cache.
    pub name: String,
    /// Default seed for stages that draw random numbers.
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub description: Option<String>,
    /// Where stages run (`local` by default) and, for a cluster, with which
    /// resources; not part of any key.
    #[serde(default)]
    pub executor: ExecutorSpec,
    /// Directories outside the pipeline file's directory whose files params
    /// may name (relative to the pipeline file, or absolute). Reading
    /// outside is refused otherwise: a pipeline file from someone else
    /// cannot make modalflow read (and quote in its errors) files it was
    /// not meant to see.
    #[serde(default)]
    pub read_outside: Vec<String>,
    pub stages: IndexMap<String, StageSpec>,
}

/// One stage entry (possibly a matrix of stages).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    pub kind: String,
    #[serde(default)]
    pub description: Option<String>,
    #[serde(default)]
    pub params: Mapping,
    /// Input name → `stage.output`, `stage[*].output` or a list of references.
    #[serde(default)]
    pub inputs: IndexMap<String, InputValue>,
    /// Matrix key → values; the stage expands to the cartesian product.
    #[serde(default)]
    pub matrix: IndexMap<String, Vec<Value>>,
}

/// An input binding as written.
#[derive(Debug, Deserialize, Clone)]
#[serde(untagged)]
pub enum InputValue {
    One(String),
    Many(Vec<String>),
}

impl InputValue {
    pub fn refs(&self) -> Vec<&str> {
        match self {
            InputValue::One(s) => vec![s.as_str()],
            InputValue::Many(v) => v.iter().map(String::as_str).collect(),
        }
    }
}

/// A parsed input reference: `stage.output`, `stage[*].output`,
/// `stage[key=value,...].output`.
#[derive(Debug, Clone, PartialEq)]
pub struct InputRef {
    pub stage: String,
    pub selector: Selector,
    pub output: String,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Selector {
    /// Plain `stage.output`.
    None,
    /// `stage[*].output`: every expansion of a matrix stage, as a list.
    All,
    /// `stage[k=v,...].output`: the expansions with these matrix values
    /// (keys in any order; naming every key selects one expansion).
    Exact(Vec<(String, String)>),
}

impl InputRef {
    /// Parse `text`; `None` when it is not of the form `stage.output`.
    pub fn parse(text: &str) -> Option<InputRef> {
        let text = text.trim();
        let name_end = text.find(['[', '.'])?;
        let stage = &text[..name_end];
        if stage.is_empty() {
            return None;
        }
        let (selector, rest) = if text[name_end..].starts_with('[') {
            let close = text[name_end..].find(']')? + name_end;
            let inner = &text[name_end + 1..close];
            let sel = if inner.trim() == "*" {
                Selector::All
            } else {
                let mut pairs = Vec::new();
                for part in inner.split(',') {
                    let (k, v) = part.split_once('=')?;
                    pairs.push((k.trim().to_string(), v.trim().to_string()));
                }
                pairs.sort();
                Selector::Exact(pairs)
            };
            (sel, &text[close + 1..])
        } else {
            (Selector::None, &text[name_end..])
        };
        let output = rest.strip_prefix('.')?;
        if output.is_empty() {
            return None;
        }
        Some(InputRef {
            stage: stage.to_string(),
            selector,
            output: output.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_reference_forms() {
        let r = InputRef::parse("truth.frf").unwrap();
        assert_eq!((r.stage.as_str(), r.output.as_str()), ("truth", "frf"));
        assert_eq!(r.selector, Selector::None);
        let r = InputRef::parse("ident[*].result").unwrap();
        assert_eq!(r.selector, Selector::All);
        let r = InputRef::parse("ident[seed=2, method=pso].result").unwrap();
        assert_eq!(
            r.selector,
            Selector::Exact(vec![
                ("method".into(), "pso".into()),
                ("seed".into(), "2".into())
            ])
        );
        // Outputs may contain dots (command outs are paths).
        let r = InputRef::parse("prep.data/out.csv").unwrap();
        assert_eq!(r.output, "data/out.csv");
        let r = InputRef::parse("sweep[noise=0.01].frf").unwrap();
        assert_eq!(r.output, "frf");
        assert!(InputRef::parse("truth").is_none());
        assert!(InputRef::parse(".frf").is_none());
        assert!(InputRef::parse("truth.").is_none());
    }
}
