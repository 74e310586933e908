//! Matrix expansion: one stage entry with `matrix: {k: [..], ...}` becomes
//! one stage per combination, named `stage[k1=v1,k2=v2]`, with
//! `${matrix.k}` substituted in params and inputs.

use indexmap::IndexMap;
use serde_yaml_ng::{Mapping, Value};

/// One combination of matrix values, keys in declaration order.
pub type Combination = Vec<(String, Value)>;

/// The cartesian product of the matrix in declaration order (last key
/// varies fastest, as in nested loops).
pub fn combinations(matrix: &IndexMap<String, Vec<Value>>) -> Vec<Combination> {
    let mut out: Vec<Combination> = vec![Vec::new()];
    for (key, values) in matrix {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                values.iter().map(move |v| {
                    let mut c = prefix.clone();
                    c.push((key.clone(), v.clone()));
                    c
                })
            })
            .collect();
    }
    out
}

/// Text of a scalar matrix value as it appears in names and string
/// substitution; `None` for non-scalars.
pub fn scalar_text(v: &Value) -> Option<String> {
    match v {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

/// `base[k1=v1,k2=v2]`, or `base` for an empty combination.
pub fn expanded_name(base: &str, combo: &Combination) -> String {
    if combo.is_empty() {
        return base.to_string();
    }
    let inner: Vec<String> = combo
        .iter()
        .map(|(k, v)| format!("{k}={}", scalar_text(v).unwrap_or_default()))
        .collect();
    format!("{base}[{}]", inner.join(","))
}

/// The inverse of [`expanded_name`]: `base[k1=v1,k2=v2]` → (`base`,
/// [(k1, v1), (k2, v2)]); a name without brackets has no matrix values.
/// Stages that compare matrix runs (an ANOVA over wear states) read their
/// factor levels from their inputs' stage names this way.
pub fn parse_expanded_name(name: &str) -> (&str, Vec<(String, String)>) {
    let Some(inner) = name
        .strip_suffix(']')
        .and_then(|n| n.split_once('['))
        .filter(|(_, inner)| !inner.is_empty())
    else {
        return (name, Vec::new());
    };
    let values = inner
        .1
        .split(',')
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) => (k.to_string(), v.to_string()),
            None => (kv.to_string(), String::new()),
        })
        .collect();
    (inner.0, values)
}

/// A `${matrix.key}` whose key the matrix does not define.
#[derive(Debug, PartialEq)]
pub struct UnknownKey {
    /// Path below the substituted root (params keys / sequence indices).
    pub path: Vec<String>,
    pub key: String,
}

/// Substitute `${matrix.key}` in every string of `value`. A string that is
/// exactly one placeholder takes the value's type (`seed: ${matrix.seed}`
/// stays an integer); otherwise the text is spliced in.
pub fn substitute(
    value: &Value,
    combo: &Combination,
    path: &mut Vec<String>,
) -> Result<Value, UnknownKey> {
    Ok(match value {
        Value::String(s) => substitute_str(s, combo, path)?,
        Value::Sequence(items) => {
            let mut out = Vec::with_capacity(items.len());
            for (i, item) in items.iter().enumerate() {
                path.push(i.to_string());
                out.push(substitute(item, combo, path)?);
                path.pop();
            }
            Value::Sequence(out)
        }
        Value::Mapping(map) => Value::Mapping(substitute_map(map, combo, path)?),
        other => other.clone(),
    })
}

pub fn substitute_map(
    map: &Mapping,
    combo: &Combination,
    path: &mut Vec<String>,
) -> Result<Mapping, UnknownKey> {
    let mut out = Mapping::new();
    for (k, v) in map {
        path.push(scalar_text(k).unwrap_or_default());
        let nv = substitute(v, combo, path)?;
        path.pop();
        out.insert(k.clone(), nv);
    }
    Ok(out)
}

pub fn substitute_str(s: &str, combo: &Combination, path: &[String]) -> Result<Value, UnknownKey> {
    const OPEN: &str = "${matrix.";
    if !s.contains(OPEN) {
        return Ok(Value::String(s.to_string()));
    }
    let lookup = |key: &str| {
        combo
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .ok_or_else(|| UnknownKey {
                path: path.to_vec(),
                key: key.to_string(),
            })
    };
    let trimmed = s.trim();
    if let Some(key) = trimmed.strip_prefix(OPEN).and_then(|r| r.strip_suffix('}')) {
        if !key.contains('}') {
            return lookup(key);
        }
    }
    let mut out = String::new();
    let mut rest = s;
    while let Some(start) = rest.find(OPEN) {
        out.push_str(&rest[..start]);
        let after = &rest[start + OPEN.len()..];
        let Some(end) = after.find('}') else {
            out.push_str(&rest[start..]);
            rest = "";
            break;
        };
        let v = lookup(&after[..end])?;
        out.push_str(&scalar_text(&v).unwrap_or_default());
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(Value::String(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expanded_names_parse_back() {
        let combo: Combination = vec![
            ("bsd".into(), Value::from(0.75)),
            ("state".into(), Value::from("worn")),
        ];
        let name = expanded_name("ema", &combo);
        assert_eq!(name, "ema[bsd=0.75,state=worn]");
        let (base, kv) = parse_expanded_name(&name);
        assert_eq!(base, "ema");
        assert_eq!(
            kv,
            [
                ("bsd".to_string(), "0.75".to_string()),
                ("state".into(), "worn".into())
            ]
        );
        assert_eq!(parse_expanded_name("plain"), ("plain", Vec::new()));
    }

    fn yaml(s: &str) -> Value {
        serde_yaml_ng::from_str(s).unwrap()
    }

    #[test]
    fn expands_cartesian_product_in_order() {
        let m: IndexMap<String, Vec<Value>> =
            serde_yaml_ng::from_str("{method: [slsqp, pso, ga], seed: [1, 2, 3]}").unwrap();
        let c = combinations(&m);
        assert_eq!(c.len(), 9);
        assert_eq!(expanded_name("ident", &c[0]), "ident[method=slsqp,seed=1]");
        assert_eq!(expanded_name("ident", &c[4]), "ident[method=pso,seed=2]");
        assert_eq!(expanded_name("ident", &c[8]), "ident[method=ga,seed=3]");
    }

    #[test]
    fn substitution_keeps_types_and_splices_text() {
        let m: IndexMap<String, Vec<Value>> =
            serde_yaml_ng::from_str("{seed: [2], method: [pso]}").unwrap();
        let combo = &combinations(&m)[0];
        let v = substitute(
            &yaml("{seed: '${matrix.seed}', tag: 'run-${matrix.method}-${matrix.seed}'}"),
            combo,
            &mut vec![],
        )
        .unwrap();
        assert_eq!(v, yaml("{seed: 2, tag: run-pso-2}"));
        let err = substitute(&yaml("{a: [x, '${matrix.nope}']}"), combo, &mut vec![]).unwrap_err();
        assert_eq!(
            err,
            UnknownKey {
                path: vec!["a".into(), "1".into()],
                key: "nope".into()
            }
        );
    }
}
