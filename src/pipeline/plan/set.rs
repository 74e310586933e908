//! `--set STAGE.PARAM=VALUE` (DVC's `exp run -S`): a param overridden for
//! one invocation. The value is YAML (`0.5`, `[1, 2]`, `{relative: 0.02}`);
//! `PARAM` may be a dotted path into a settings mapping (`noise.relative`);
//! `STAGE` is a stage's base name (every expansion) or one expansion. The
//! override replaces the value before the params are parsed, so it is
//! checked like the file's own values and enters the key, the manifest and
//! `status`'s reasons (`param budget changed 5000 -> 200`).

use serde_yaml_ng::{Mapping, Value};

/// One parsed `--set`.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    /// As given on the command line.
    pub text: String,
    pub stage: String,
    pub path: Vec<String>,
    pub value: Value,
}

impl Override {
    /// Parse `STAGE.PARAM[.SUB…]=VALUE`.
    pub fn parse(text: &str) -> Result<Override, String> {
        let bad = |why: &str| {
            format!("--set {text}: {why}; write STAGE.PARAM=VALUE, e.g. --set ema.iterations=80")
        };
        let (lhs, rhs) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
        // An expansion's name holds dots and `=` only inside its brackets.
        let (lhs, rhs) = match (lhs.find('['), text.find(']')) {
            (Some(open), Some(close)) if open < lhs.len() && close > open => {
                let after = &text[close + 1..];
                let (rest, value) = after.split_once('=').ok_or_else(|| bad("no `=`"))?;
                (format!("{}{rest}", &text[..=close]), value)
            }
            _ => (lhs.to_string(), rhs),
        };
        let split_at = match lhs.rfind(']') {
            Some(close) => lhs[close..].find('.').map(|i| close + i),
            None => lhs.find('.'),
        };
        let at = split_at.ok_or_else(|| bad("no `.` between the stage and the param"))?;
        let stage = lhs[..at].trim().to_string();
        let path: Vec<String> = lhs[at + 1..]
            .split('.')
            .map(|p| p.trim().to_string())
            .collect();
        if stage.is_empty() || path.iter().any(String::is_empty) {
            return Err(bad("empty stage or param name"));
        }
        let value: Value = serde_yaml_ng::from_str(rhs)
            .map_err(|e| bad(&format!("the value is not YAML ({e})")))?;
        Ok(Override {
            text: text.to_string(),
            stage,
            path,
            value,
        })
    }

    /// Whether it applies to the expansion `name` of stage entry `base`.
    pub fn applies(&self, base: &str, name: &str) -> bool {
        self.stage == base || self.stage == name
    }

    /// Set the value in `params`, creating mappings along the path.
    pub fn apply(&self, params: &mut Mapping) {
        let mut map = params;
        for (i, key) in self.path.iter().enumerate() {
            let k = Value::String(key.clone());
            if i + 1 == self.path.len() {
                map.insert(k, self.value.clone());
                return;
            }
            if !matches!(map.get(&k), Some(Value::Mapping(_))) {
                map.insert(k.clone(), Value::Mapping(Mapping::new()));
            }
            match map.get_mut(&k) {
                Some(Value::Mapping(m)) => map = m,
                _ => return,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_stage_path_and_yaml_value() {
        let o = Override::parse("ema.iterations=80").expect("valid");
        assert_eq!(
            (o.stage.as_str(), o.path.clone()),
            ("ema", vec!["iterations".to_string()])
        );
        assert_eq!(o.value, Value::from(80));
        let o = Override::parse("truth.noise.relative=0.02").expect("valid");
        assert_eq!(o.path, ["noise", "relative"]);
        let o = Override::parse("ident[method=pso,seed=2].budget=100").expect("valid");
        assert_eq!(o.stage, "ident[method=pso,seed=2]");
        assert_eq!(o.path, ["budget"]);
        assert!(o.applies("ident", "ident[method=pso,seed=2]"));
        assert!(!o.applies("ident", "ident[method=ga,seed=2]"));
        let o = Override::parse("s.bands=[[1, 2], [3, 4]]").expect("valid");
        assert!(matches!(o.value, Value::Sequence(_)));
        for bad in ["ema", "ema=3", "ema.=3", ".x=3", "ema.x=[1"] {
            assert!(Override::parse(bad).is_err(), "{bad}");
        }
        let mut m = Mapping::new();
        Override::parse("t.noise.relative=0.5")
            .expect("valid")
            .apply(&mut m);
        assert_eq!(
            serde_yaml_ng::to_string(&m).expect("yaml").trim(),
            "noise:\n  relative: 0.5"
        );
    }
}
