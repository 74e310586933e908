//! Model-file helpers shared by the structural-dynamics tests.

use modalflow::dynamics::{Model, PreparedModel};

/// A resolver that has no files: models that name none load through it.
pub fn no_files(p: &str) -> std::io::Result<Vec<u8>> {
    Err(std::io::Error::new(
        std::io::ErrorKind::NotFound,
        format!("{p}: not found"),
    ))
}

/// The error a bad model file (named `bad.yaml`) gives.
pub fn err_of(text: &str) -> String {
    match Model::from_yaml(text, "bad.yaml", &no_files).and_then(|m| PreparedModel::new(&m)) {
        Ok(_) => panic!("accepted a bad model"),
        Err(e) => e.to_string(),
    }
}

/// Each bad model text gives an error naming `bad.yaml` and its expected
/// part (the field, the unknown name).
pub fn assert_errors(cases: &[(String, &str)]) {
    for (text, expect) in cases {
        let e = err_of(text);
        assert!(
            e.contains("bad.yaml") && e.contains(expect),
            "expected `{expect}` in: {e}"
        );
    }
}
