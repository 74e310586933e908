//! Run records: `runs/<key>.json` maps a stage key to its output hashes,
//! seconds and counters. Written last, after every object, and sealed: the
//! record names its key and ends with a checksum of its own text, so a
//! record edited after it was written, or written for another key, is
//! corrupt (and the stage recomputed) rather than trusted. With a cache key
//! (`MODALFLOW_CACHE_KEY_FILE`) the checksum is a keyed hash, so a record
//! written by anyone without the key — a forged one in a shared cache —
//! is recomputed, never used. Without a key, every name and hash in a
//! record is still checked before it becomes a path ([`crate::paths`]).

use super::store::{err, OutputRecord, Result, Store};
use crate::paths;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs;
use std::io;
use std::path::PathBuf;

/// The cache entry for one stage key. Written last, after every object.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunRecord {
    pub key: String,
    pub kind: String,
    pub version: u32,
    /// Stage that first produced it (informational; keys do not depend on names).
    pub stage: String,
    pub outputs: BTreeMap<String, OutputRecord>,
    pub seconds: f64,
    pub counters: BTreeMap<String, u64>,
    /// The stage's warnings ([`crate::stages::StageOutputs::warnings`]);
    /// absent in records without any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    pub modalflow_version: String,
    /// blake3 of the record file's text without this field (the last one):
    /// a record edited after it was written (a swapped output hash that
    /// still parses) is told apart from a genuine one and recomputed. Set by
    /// [`Store::write_record`]; over the text, not re-serialized values, so
    /// float parsing cannot make a genuine record look edited.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub checksum: String,
}

/// The seal of a record's text: blake3, keyed with the cache key when one
/// is set (`MODALFLOW_CACHE_KEY_FILE`), so that only holders of the key can
/// write records a keyed reader accepts.
fn seal(text: &[u8], key: Option<&[u8; 32]>) -> blake3::Hash {
    match key {
        Some(k) => blake3::keyed_hash(k, text),
        None => blake3::hash(text),
    }
}

impl RunRecord {
    /// The record file's text: the record's pretty JSON with the checksum
    /// of that text appended as the last field.
    fn sealed_text(&self, key: Option<&[u8; 32]>) -> String {
        let mut bare = self.clone();
        bare.checksum.clear();
        let text = serde_json::to_string_pretty(&bare).unwrap_or_default();
        let sum = seal(text.as_bytes(), key).to_hex();
        let body = text.strip_suffix("\n}").unwrap_or(&text);
        format!("{body},\n  \"checksum\": \"{sum}\"\n}}")
    }
}

/// Whether a record file's text carries the checksum of the rest of it
/// (the inverse of [`RunRecord::sealed_text`]).
fn seal_matches(text: &[u8], checksum: &str, key: Option<&[u8; 32]>) -> bool {
    let tail = format!(",\n  \"checksum\": \"{checksum}\"\n}}");
    let Some(body) = text.strip_suffix(tail.as_bytes()) else {
        return false;
    };
    let mut bare = body.to_vec();
    bare.extend_from_slice(b"\n}");
    seal(&bare, key).to_hex().as_str() == checksum
}

/// What a record says that becomes a path: every output's object hash and
/// file name. A record is untrusted input (a shared or published cache):
/// anything that would leave the results or workspace folder is refused.
fn check_paths(rec: &RunRecord) -> std::result::Result<(), String> {
    for (name, out) in &rec.outputs {
        if !paths::is_hash(&out.artifact.hash) {
            return Err(format!(
                "run record: output `{name}` has no valid object hash"
            ));
        }
        match paths::relative(&out.file) {
            Ok(rel) if rel == out.file => {}
            _ => {
                return Err(format!(
                    "run record: output `{name}` has file name `{}`, which would leave its folder",
                    out.file.escape_debug()
                ))
            }
        }
    }
    Ok(())
}

/// Names the file holding a shared cache's secret; see [`Store::seal_key`].
pub const KEY_ENV: &str = "MODALFLOW_CACHE_KEY_FILE";

/// The seal key from the file `MODALFLOW_CACHE_KEY_FILE` names, if set:
/// blake3's key derivation over the file's bytes (any length of secret).
pub(super) fn seal_key_from_env() -> Result<Option<[u8; 32]>> {
    let Some(path) = std::env::var_os(KEY_ENV) else {
        return Ok(None);
    };
    let path = PathBuf::from(path);
    let secret = fs::read(&path).map_err(err("read the cache key file", &path))?;
    if secret.len() < 16 {
        return Err(err("use the cache key file", &path)(io::Error::new(
            io::ErrorKind::InvalidData,
            "it holds fewer than 16 bytes; put a long random secret there \
             (e.g. `head -c 32 /dev/urandom > FILE`)",
        )));
    }
    Ok(Some(blake3::derive_key(
        "modalflow cache run-record seal v1",
        &secret,
    )))
}

impl Store {
    pub(crate) fn record_path(&self, key: &str) -> PathBuf {
        self.root().join("runs").join(format!("{key}.json"))
    }

    /// The run record for `key`, if one was committed and is intact.
    pub fn record(&self, key: &str) -> Option<RunRecord> {
        self.read_record(key).ok().flatten()
    }

    /// The run record for `key`: `Ok(None)` when there is none, `Err` with
    /// what is wrong when one is there but cannot be trusted (unreadable,
    /// not a record, written for another key, checksum missing or not
    /// matching its content).
    pub fn read_record(&self, key: &str) -> std::result::Result<Option<RunRecord>, String> {
        let path = self.record_path(key);
        let bytes = match fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("run record {} is unreadable: {e}", path.display())),
        };
        let rec: RunRecord = serde_json::from_slice(&bytes)
            .map_err(|e| format!("run record is not a valid record: {e}"))?;
        if rec.key != key {
            return Err(format!("run record belongs to key {}", rec.key));
        }
        if rec.checksum.is_empty() {
            return Err("run record has no checksum".into());
        }
        if !seal_matches(&bytes, &rec.checksum, self.seal_key()) {
            return Err(if self.seal_key().is_some() {
                "run record is not sealed with this cache's key (MODALFLOW_CACHE_KEY_FILE), or \
                 was edited after it was written"
                    .into()
            } else {
                "run record does not match its checksum (edited after it was written, or \
                 sealed with a cache key this run does not have)"
                    .into()
            });
        }
        check_paths(&rec)?;
        Ok(Some(rec))
    }

    /// Commit a run record (the last write of a stage run), sealed with
    /// its checksum.
    pub fn write_record(&self, rec: &RunRecord) -> Result<()> {
        let text = rec.sealed_text(self.seal_key());
        self.write_atomic(&self.record_path(&rec.key), text.as_bytes())
    }

    pub fn remove_record(&self, key: &str) {
        let _ = fs::remove_file(self.record_path(key));
    }
}
