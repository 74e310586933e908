//! Every pipeline shipped in `pipelines/` validates: the studies stay in
//! step with the stage kinds and the model files.

use crate::util;

#[test]
fn every_shipped_pipeline_validates() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/pipelines");
    let mut seen = 0;
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "yaml") {
            continue;
        }
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_modalflow"))
            .args(["validate", path.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}: {}",
            path.display(),
            util::text(&out.stderr)
        );
        seen += 1;
    }
    assert!(seen >= 3, "found only {seen} pipelines");
}
