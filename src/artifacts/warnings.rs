//! `warnings`: a read-only view of the `warnings` every stage summary
//! carries — AutoEMA's metrics.json, gsa's subproblems.json, import's
//! import.json (a top-level `warnings` array) and an identify cost.json
//! (`verdict.warnings`) — so the report can list every stage's warnings
//! through one reader. The writers keep their own schemas; this one names
//! only the field they share.

use super::{read_json, ArtifactError};
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Default, Deserialize)]
struct Summary {
    #[serde(default)]
    warnings: Vec<String>,
    #[serde(default)]
    verdict: Option<VerdictWarnings>,
}

#[derive(Debug, Default, Deserialize)]
struct VerdictWarnings {
    #[serde(default)]
    warnings: Vec<String>,
}

/// The warnings of a stage summary: its top-level `warnings`, then its
/// verdict's. A JSON object without either has none; anything else (not
/// JSON, not an object) is refused.
pub fn read(path: &Path) -> Result<Vec<String>, ArtifactError> {
    let s: Summary = read_json(path, "a stage summary (JSON object)")?;
    let mut out = s.warnings;
    out.extend(s.verdict.map(|v| v.warnings).unwrap_or_default());
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::read;

    #[test]
    fn reads_top_level_and_verdict_warnings() {
        let dir = std::env::temp_dir().join(format!("mf-warnings-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.json");
        std::fs::write(
            &p,
            r#"{"warnings": ["a"], "verdict": {"ok": false, "warnings": ["b"]}}"#,
        )
        .unwrap();
        assert_eq!(read(&p).unwrap(), ["a", "b"]);
        std::fs::write(&p, r#"{"n_modes": 3}"#).unwrap();
        assert!(read(&p).unwrap().is_empty());
        std::fs::write(&p, "[1, 2]").unwrap();
        assert!(read(&p).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
