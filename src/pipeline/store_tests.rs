//! Tests of `store`, kept apart to keep the module short.
use super::*;
use std::collections::BTreeMap;

#[test]
fn put_verify_checkout_roundtrip_and_corruption() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&dir.path().join("cache")).unwrap();
    let src = dir.path().join("a.txt");
    fs::write(&src, b"hello").unwrap();
    let a = store.put(&src).unwrap();
    assert_eq!(a.hash, blake3::hash(b"hello").to_hex().to_string());
    assert_eq!(a.hash, hash_path(&src).unwrap());
    assert!(store.verify(&a).is_ok());

    let tree_src = dir.path().join("d");
    fs::create_dir_all(tree_src.join("sub")).unwrap();
    fs::write(tree_src.join("x"), b"1").unwrap();
    fs::write(tree_src.join("sub/y"), b"2").unwrap();
    let t = store.put(&tree_src).unwrap();
    assert_eq!(t.kind, ArtifactKind::Dir);
    assert_eq!(t.hash, hash_path(&tree_src).unwrap());
    let out = dir.path().join("out");
    store.checkout(&t, &out).unwrap();
    assert_eq!(fs::read(out.join("sub/y")).unwrap(), b"2");

    let rec = RunRecord {
        key: "k".into(),
        kind: "command".into(),
        version: 1,
        stage: "s".into(),
        outputs: BTreeMap::new(),
        // Not exactly representable sums parse back 1 ulp off in
        // serde_json's fast float path: the seal must not care.
        seconds: 0.009991630000000001,
        counters: BTreeMap::new(),
        warnings: Vec::new(),
        modalflow_version: "0".into(),
        checksum: String::new(),
    };
    store.write_record(&rec).unwrap();
    assert!(store.read_record("k").unwrap().is_some());
    let path = store.record_path("k");
    let text = fs::read_to_string(&path).unwrap();
    fs::write(&path, text.replace("\"s\"", "\"t\"")).unwrap();
    assert!(store.read_record("k").unwrap_err().contains("checksum"));

    fs::write(store.object_path(&a.hash), b"hellO").unwrap();
    let e = store.verify(&a).unwrap_err();
    assert!(e.contains("corrupt"), "{e}");
}
