//! Cache keys: blake3 over the canonical form of everything that determines
//! a stage's result — kind, kind version, params, seed, the content hashes of
//! its input artifacts and of the files its params name.
//!
//! Canonical params are JSON with sorted keys and floats in Rust's shortest
//! round-trip text, so `0.1` is always `0.1` and key order in the YAML does
//! not matter. No absolute paths, mtimes or host names enter a key.

use crate::stages::UpstreamWarnings;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value as Json};
use serde_yaml_ng::Value;
use std::collections::BTreeMap;

/// Everything that determines a stage's outputs. Stored as the stage's
/// provenance after a run, so `status` can say what changed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct KeyMaterial {
    pub kind: String,
    pub version: u32,
    pub params: Json,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Input name → content hashes of the bound artifacts, in order.
    pub inputs: BTreeMap<String, Vec<String>>,
    /// Param-named file (normalized relative path) → content hash.
    pub files: BTreeMap<String, String>,
    /// For kinds that read them, the warnings of every upstream stage with
    /// any, in plan order (absent otherwise, so other keys are unchanged).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub upstream_warnings: Vec<UpstreamWarnings>,
}

impl KeyMaterial {
    /// The stage key: blake3 of the canonical JSON, hex.
    pub fn key(&self) -> String {
        let text = serde_json::to_string(&canonical_json(
            &serde_json::to_value(self).unwrap_or(Json::Null),
        ))
        .unwrap_or_default();
        blake3::hash(text.as_bytes()).to_hex().to_string()
    }
}

/// YAML params → JSON with sorted keys. Non-string keys become their text;
/// tagged values become `{"!tag": value}`.
pub fn canonical_params(v: &Value) -> Json {
    match v {
        Value::Null => Json::Null,
        Value::Bool(b) => Json::Bool(*b),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                Json::from(i)
            } else if let Some(u) = n.as_u64() {
                Json::from(u)
            } else {
                n.as_f64()
                    .and_then(serde_json::Number::from_f64)
                    .map(Json::Number)
                    .unwrap_or(Json::Null)
            }
        }
        Value::String(s) => Json::String(s.clone()),
        Value::Sequence(items) => Json::Array(items.iter().map(canonical_params).collect()),
        Value::Mapping(m) => {
            let sorted: BTreeMap<String, Json> = m
                .iter()
                .map(|(k, v)| (key_text(k), canonical_params(v)))
                .collect();
            Json::Object(sorted.into_iter().collect::<Map<_, _>>())
        }
        Value::Tagged(t) => {
            let mut m = Map::new();
            m.insert(t.tag.to_string(), canonical_params(&t.value));
            Json::Object(m)
        }
    }
}

fn key_text(k: &Value) -> String {
    match k {
        Value::String(s) => s.clone(),
        other => serde_yaml_ng::to_string(other)
            .map(|s| s.trim_end().to_string())
            .unwrap_or_default(),
    }
}

/// Re-sort every object of an arbitrary JSON value (serde_json keeps
/// insertion order in this crate).
pub fn canonical_json(v: &Json) -> Json {
    match v {
        Json::Object(m) => {
            let sorted: BTreeMap<&String, Json> =
                m.iter().map(|(k, v)| (k, canonical_json(v))).collect();
            Json::Object(sorted.into_iter().map(|(k, v)| (k.clone(), v)).collect())
        }
        Json::Array(a) => Json::Array(a.iter().map(canonical_json).collect()),
        other => other.clone(),
    }
}

/// Leaf-level differences between two canonical param trees, as
/// `frequency.step changed 0.5 -> 0.25`, `noise added`, `x removed`.
pub fn param_changes(old: &Json, new: &Json) -> Vec<String> {
    let mut out = Vec::new();
    diff(old, new, &mut String::new(), &mut out);
    out
}

fn diff(old: &Json, new: &Json, path: &mut String, out: &mut Vec<String>) {
    match (old, new) {
        (Json::Object(a), Json::Object(b)) => {
            let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
            for k in keys {
                let len = path.len();
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(k);
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => diff(x, y, path, out),
                    (None, Some(y)) => out.push(format!("{path} added ({})", short(y))),
                    (Some(_), None) => out.push(format!("{path} removed")),
                    (None, None) => {}
                }
                path.truncate(len);
            }
        }
        (a, b) if a != b => out.push(format!("{path} changed {} -> {}", short(a), short(b))),
        _ => {}
    }
}

fn short(v: &Json) -> String {
    let s = v.to_string();
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(39).collect::<String>())
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(s: &str) -> Json {
        canonical_params(&serde_yaml_ng::from_str(s).unwrap())
    }

    fn material(p: Json) -> KeyMaterial {
        KeyMaterial {
            kind: "k".into(),
            version: 1,
            params: p,
            seed: None,
            inputs: BTreeMap::new(),
            files: BTreeMap::new(),
            upstream_warnings: Vec::new(),
        }
    }

    #[test]
    fn key_ignores_key_order_but_not_values() {
        let a = material(params("{b: 1, a: {y: 0.1, x: [1, 2]}}"));
        let b = material(params("{a: {x: [1, 2], y: 0.1}, b: 1}"));
        assert_eq!(a.key(), b.key());
        let c = material(params("{a: {x: [1, 2], y: 0.10000000000000002}, b: 1}"));
        assert_ne!(a.key(), c.key());
        let mut d = b.clone();
        d.version = 2;
        assert_ne!(a.key(), d.key());
        let mut e = b.clone();
        e.inputs.insert("frf".into(), vec!["abc".into()]);
        assert_ne!(a.key(), e.key());
        assert_eq!(a.key().len(), 64);
        // No upstream warnings: not in the canonical text (older keys stay);
        // a changed upstream warning changes the key.
        let text = serde_json::to_string(&a).unwrap();
        assert!(!text.contains("upstream_warnings"), "{text}");
        let mut f = b.clone();
        f.upstream_warnings.push(UpstreamWarnings {
            stage: "ema".into(),
            warnings: vec!["position 0: mode missed".into()],
        });
        assert_ne!(a.key(), f.key());
        let mut g = f.clone();
        g.upstream_warnings[0].warnings[0].push('!');
        assert_ne!(f.key(), g.key());
    }

    #[test]
    fn changes_name_leaf_paths() {
        let old = params("{frequency: {min: 0, step: 0.5}, noise: 1}");
        let new = params("{frequency: {min: 0, step: 0.25}, seed: 3}");
        assert_eq!(
            param_changes(&old, &new),
            vec![
                "frequency.step changed 0.5 -> 0.25",
                "noise removed",
                "seed added (3)"
            ]
        );
    }
}
