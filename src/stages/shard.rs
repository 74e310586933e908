//! Sharding a stage's batch of independent model evaluations over the tasks
//! of a cluster job array.
//!
//! A shardable stage ([`super::Stage::shardable`]) hands its batch — the
//! points of a Saltelli design, say — to [`super::StageContext::evaluate_batch`]
//! instead of evaluating it itself. What happens then depends on the
//! [`Batch`] role the executor gave this run of the stage:
//!
//! - **whole**: every point is evaluated here (a local run);
//! - **shard i of m**: only the points of slice i are evaluated; they are
//!   written as a partial result and the stage stops with
//!   [`EvalError::Sharded`];
//! - **merge**: the partials of all m shards are read instead of evaluating,
//!   and the stage goes on exactly as a whole run would.
//!
//! Slices are contiguous and fixed by (number of points, i, m). A partial
//! records the hash of the whole batch's points, so a merge never combines
//! partials of another batch, and stores model outputs bit for bit (raw
//! little-endian f64): a sharded run is bit-identical to a local one.
//! Only a run's first batch is sharded; later batches (if a stage has any)
//! are evaluated whole by the merge.

use crate::simulator::{evaluate_all, EvalError, Model};
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// First line of a partial-result file.
const MAGIC: &str = "modalflow-partial 1";

/// What [`Batch::evaluate`] does with a run's first batch.
#[derive(Clone, Debug)]
pub enum Role {
    Whole,
    /// Evaluate slice `index` of `count` and write it to `out`.
    Shard {
        index: usize,
        count: usize,
        out: PathBuf,
    },
    /// Read the batch's outputs from these partial files (any order).
    Merge {
        partials: Vec<PathBuf>,
    },
}

/// The batch role of one stage run, with what the run has done so far.
#[derive(Debug)]
pub struct Batch {
    role: Role,
    calls: AtomicUsize,
    written: Mutex<Option<PathBuf>>,
}

/// Header of a partial result: which batch, which slice, how wide.
#[derive(Debug, serde::Serialize, serde::Deserialize, PartialEq)]
struct Header {
    /// blake3 of the whole batch's points ([`points_hash`]).
    points: String,
    items: usize,
    start: usize,
    end: usize,
    outputs: usize,
}

impl Batch {
    pub fn new(role: Role) -> Batch {
        Batch {
            role,
            calls: AtomicUsize::new(0),
            written: Mutex::new(None),
        }
    }

    /// A local run: everything is evaluated here.
    pub fn whole() -> Batch {
        Batch::new(Role::Whole)
    }

    /// The partial file this run wrote, if it was a shard that got its batch.
    pub fn written(&self) -> Option<PathBuf> {
        self.written.lock().ok().and_then(|w| w.clone())
    }

    /// Evaluate `xs` (outputs in input order, all finite) according to the
    /// role; `progress` receives the number of points done.
    pub fn evaluate(
        &self,
        model: &(impl Model + ?Sized),
        xs: &[Vec<f64>],
        chunk: usize,
        progress: &dyn Fn(u64),
    ) -> Result<Vec<Vec<f64>>, EvalError> {
        let first = self.calls.fetch_add(1, Ordering::SeqCst) == 0;
        match &self.role {
            Role::Shard { index, count, out } if first => {
                let range = slice(xs.len(), *index, *count);
                let ys = evaluate_all(model, &xs[range.clone()], chunk, progress)
                    .map_err(|e| shifted(e, range.start))?;
                let header = Header {
                    points: points_hash(xs),
                    items: xs.len(),
                    start: range.start,
                    end: range.end,
                    outputs: model.outputs().len(),
                };
                write_partial(out, &header, &ys).map_err(|e| {
                    EvalError::Partial(format!("cannot write {}: {e}", out.display()))
                })?;
                if let Ok(mut w) = self.written.lock() {
                    *w = Some(out.clone());
                }
                Err(EvalError::Sharded)
            }
            Role::Merge { partials } if first => {
                let ys = merge(partials, xs, model.outputs().len())?;
                progress(xs.len() as u64);
                Ok(ys)
            }
            _ => evaluate_all(model, xs, chunk, progress),
        }
    }
}

/// Items of shard `index` of `count`: contiguous, in order, sizes differing
/// by at most one, together exactly `0..items`.
pub fn slice(items: usize, index: usize, count: usize) -> Range<usize> {
    let count = count.max(1);
    items * index / count..items * (index + 1) / count
}

/// blake3 over the number of points and their values' bits.
fn points_hash(xs: &[Vec<f64>]) -> String {
    let mut h = blake3::Hasher::new();
    h.update(&(xs.len() as u64).to_le_bytes());
    for x in xs {
        h.update(&(x.len() as u64).to_le_bytes());
        for v in x {
            h.update(&v.to_le_bytes());
        }
    }
    h.finalize().to_hex().to_string()
}

/// A failure inside a slice, with sample indices of the whole batch.
fn shifted(e: EvalError, start: usize) -> EvalError {
    match e {
        EvalError::Batch {
            failed,
            total,
            first,
        } => EvalError::Batch {
            failed,
            total,
            first: Box::new(first.at_sample(start)),
        },
        other => other.at_sample(start),
    }
}

fn write_partial(path: &Path, header: &Header, ys: &[Vec<f64>]) -> std::io::Result<()> {
    let mut bytes = Vec::with_capacity(128 + ys.len() * header.outputs * 8);
    writeln!(bytes, "{MAGIC}")?;
    serde_json::to_writer(&mut bytes, header)?;
    bytes.push(b'\n');
    for y in ys {
        for v in y {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, bytes)
}

fn read_partial(path: &Path) -> Result<(Header, Vec<f64>), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let bad = || format!("{} is not a partial result", path.display());
    let mut lines = bytes.splitn(3, |b| *b == b'\n');
    if lines.next() != Some(MAGIC.as_bytes()) {
        return Err(bad());
    }
    let header: Header = serde_json::from_slice(lines.next().ok_or_else(bad)?)
        .map_err(|e| format!("{}: {e}", bad()))?;
    let data = lines.next().unwrap_or_default();
    let expected = (header.end.saturating_sub(header.start)) * header.outputs * 8;
    if data.len() != expected {
        return Err(format!(
            "{} is truncated: {} bytes of values, expected {expected}",
            path.display(),
            data.len()
        ));
    }
    let values = data
        .chunks_exact(8)
        .map(|c| {
            let mut b = [0u8; 8];
            b.copy_from_slice(c);
            f64::from_le_bytes(b)
        })
        .collect();
    Ok((header, values))
}

/// The batch's outputs from its shards' partials, checked to be exactly
/// this batch's points, covered once.
fn merge(
    partials: &[PathBuf],
    xs: &[Vec<f64>],
    outputs: usize,
) -> Result<Vec<Vec<f64>>, EvalError> {
    let hash = points_hash(xs);
    let mut parts = Vec::with_capacity(partials.len());
    for p in partials {
        let (header, values) = read_partial(p).map_err(EvalError::Partial)?;
        if header.points != hash || header.items != xs.len() || header.outputs != outputs {
            return Err(EvalError::Partial(format!(
                "{} belongs to another batch ({} points, {} outputs; this run has {} and {}): \
                 the stage's batch is not a deterministic function of its params and inputs",
                p.display(),
                header.items,
                header.outputs,
                xs.len(),
                outputs
            )));
        }
        parts.push((header, values));
    }
    parts.sort_by_key(|(h, _)| h.start);
    let mut ys = Vec::with_capacity(xs.len());
    for (h, values) in parts {
        if h.start != ys.len() {
            return Err(EvalError::Partial(format!(
                "the shards cover points {}..{} after {}: a slice is missing or repeated",
                h.start,
                h.end,
                ys.len()
            )));
        }
        ys.extend(values.chunks_exact(outputs.max(1)).map(<[f64]>::to_vec));
        if outputs == 0 {
            ys.extend((h.start..h.end).map(|_| Vec::new()));
        }
    }
    if ys.len() != xs.len() {
        return Err(EvalError::Partial(format!(
            "the shards cover {} of {} points",
            ys.len(),
            xs.len()
        )));
    }
    Ok(ys)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::Ishigami;

    fn points(n: usize) -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| {
                let t = i as f64 / n as f64;
                vec![3.0 * t - 1.5, 0.7 - t, (5.0 * t).sin()]
            })
            .collect()
    }

    #[test]
    fn slices_partition_the_items() {
        for items in [0, 1, 3, 10, 1000, 1001] {
            for count in [1, 2, 3, 4, 7, 16] {
                let mut next = 0;
                for i in 0..count {
                    let r = slice(items, i, count);
                    assert_eq!(r.start, next);
                    assert!(r.len() + 1 >= items / count && r.len() <= items / count + 1);
                    next = r.end;
                }
                assert_eq!(next, items);
            }
        }
    }

    #[test]
    fn shards_then_merge_equal_a_whole_evaluation_bit_for_bit() {
        let dir = tempfile::tempdir().expect("temp dir");
        let m = Ishigami::new();
        let xs = points(103);
        let whole = Batch::whole()
            .evaluate(&m, &xs, 16, &|_| {})
            .expect("whole");
        let mut partials = Vec::new();
        for i in (0..4).rev() {
            let out = dir.path().join(format!("part{i}"));
            let b = Batch::new(Role::Shard {
                index: i,
                count: 4,
                out: out.clone(),
            });
            let r = b.evaluate(&m, &xs, 16, &|_| {});
            assert!(matches!(r, Err(EvalError::Sharded)), "{r:?}");
            assert_eq!(b.written(), Some(out.clone()));
            partials.push(out);
        }
        let merge = Batch::new(Role::Merge {
            partials: partials.clone(),
        });
        let merged = merge.evaluate(&m, &xs, 16, &|_| {}).expect("merge");
        let bits =
            |ys: &[Vec<f64>]| -> Vec<u64> { ys.iter().flatten().map(|v| v.to_bits()).collect() };
        assert_eq!(bits(&merged), bits(&whole));
        // A second batch of the same run is evaluated, not merged.
        let again = merge
            .evaluate(&m, &xs[..5], 16, &|_| {})
            .expect("second batch");
        assert_eq!(bits(&again), bits(&whole[..5]));

        // Partials of another batch, or a missing slice, are refused.
        let mut other = xs.clone();
        other[7][1] += 1e-12;
        let e = Batch::new(Role::Merge {
            partials: partials.clone(),
        })
        .evaluate(&m, &other, 16, &|_| {});
        assert!(
            matches!(&e, Err(EvalError::Partial(t)) if t.contains("another batch")),
            "{e:?}"
        );
        let e = Batch::new(Role::Merge {
            partials: partials[1..].to_vec(),
        })
        .evaluate(&m, &xs, 16, &|_| {});
        assert!(matches!(e, Err(EvalError::Partial(_))), "{e:?}");
        std::fs::write(&partials[0], b"modalflow-partial 1\n{}").expect("write");
        let e = Batch::new(Role::Merge { partials }).evaluate(&m, &xs, 16, &|_| {});
        assert!(matches!(e, Err(EvalError::Partial(_))), "{e:?}");
    }

    #[test]
    fn a_failed_sample_is_named_by_its_index_in_the_whole_batch() {
        let dir = tempfile::tempdir().expect("temp dir");
        let m = Ishigami::new();
        let mut xs = points(40);
        xs[33] = vec![0.1];
        let b = Batch::new(Role::Shard {
            index: 3,
            count: 4,
            out: dir.path().join("p"),
        });
        let e = b
            .evaluate(&m, &xs, 4, &|_| {})
            .expect_err("sample 33 fails");
        assert_eq!(e.sample_index(), Some(33), "{e}");
        assert_eq!(b.written(), None);
    }
}
