//! Model evaluation: the one interface through which sensitivity analysis and
//! identification run a model — a function from named, bounded parameters to
//! named scalar outputs.
//!
//! - [`Parameter`] / [`Scale`]: bounds and the map to the unit interval.
//! - [`Model`]: `evaluate` one point, `evaluate_batch` many (in parallel by
//!   default, results in input order whatever the thread count).
//! - [`Counted`]: a wrapper counting evaluations (the cost measure reported
//!   by every strategy).
//! - Sources: [`builtin`] test functions with analytic sensitivity indices
//!   (Ishigami, Sobol-G) and [`command`], a user's own simulator speaking
//!   JSON lines, and [`structural`], a modalflow model file with reference
//!   modes (eigenfrequency, damping ratio, MAC per position and mode).
//!
//! Points are physical values in parameter order (not unit coordinates);
//! outputs come in the order of [`Model::outputs`].

pub mod builtin;
pub mod command;
pub mod frf_bands;
pub mod structural;

pub use crate::parameter::{Parameter, ParameterError, Scale};
pub use builtin::{Ishigami, SobolG};
pub use command::{CommandModel, CommandOptions};
pub use frf_bands::{BandOptions, FrfBands};
pub use structural::{StructuralModel, StructuralOptions};

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Why a model evaluation failed.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The point has the wrong number of values.
    #[error("expected {expected} parameter values, got {got}")]
    Dimension { expected: usize, got: usize },
    /// The model is undefined at this point or returned a non-finite output.
    #[error("{0}")]
    Domain(String),
    /// The external command could not be started.
    #[error("cannot start `{command}`: {source}; check the command and that it is executable")]
    Spawn {
        command: String,
        #[source]
        source: std::io::Error,
    },
    /// The external command failed or broke the JSON-lines protocol.
    #[error("{0}")]
    Command(String),
    /// The external command did not answer in time.
    #[error(
        "no answer within the timeout of {seconds} s; raise `timeout` or make the model faster"
    )]
    Timeout { seconds: f64 },
    /// The error of one sample of a batch, with its 0-based index.
    #[error("sample {index}: {source}")]
    Sample {
        index: usize,
        #[source]
        source: Box<EvalError>,
    },
    /// Some samples of a batch failed; `first` is the one with the lowest index.
    #[error("{failed} of {total} evaluations failed; first: {first}")]
    Batch {
        failed: usize,
        total: usize,
        first: Box<EvalError>,
    },
    /// Not a failure: this process evaluated its shard of the batch and wrote
    /// the partial result; the stage stops here and a merge run goes on
    /// (`crate::stages::shard`).
    #[error("shard evaluated; the merge job continues the stage")]
    Sharded,
    /// A shard's partial result cannot be used (missing, corrupt, or of
    /// another batch).
    #[error("partial result of a shard: {0}")]
    Partial(String),
}

impl EvalError {
    /// Attach the sample index `index` (within a batch); an error that already
    /// carries an index is shifted by `index` instead, so indices of a chunk
    /// evaluated at an offset become indices of the whole batch.
    pub fn at_sample(self, index: usize) -> EvalError {
        match self {
            EvalError::Sample { index: i, source } => EvalError::Sample {
                index: index + i,
                source,
            },
            other => EvalError::Sample {
                index,
                source: Box::new(other),
            },
        }
    }

    /// The sample index, when the error carries one.
    pub fn sample_index(&self) -> Option<usize> {
        match self {
            EvalError::Sample { index, .. } => Some(*index),
            EvalError::Batch { first, .. } => first.sample_index(),
            _ => None,
        }
    }
}

/// A model: parameters in, named scalar outputs out.
///
/// Implementations must be deterministic functions of the point (no hidden
/// state that depends on evaluation order), so that parallel batches give the
/// same results for any thread count.
pub trait Model: Sync {
    /// The parameters, in the order of the values of a point.
    fn parameters(&self) -> &[Parameter];
    /// Output names, in the order of the values `evaluate` returns.
    fn outputs(&self) -> &[String];
    /// Outputs at one point (physical parameter values).
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError>;
    /// The modes the outputs name (`p<i>.mode<r>`, frequency in Hz), for a
    /// model with modal outputs; an identification finds them again by
    /// frequency when its reference is numbered differently.
    fn named_modes(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
    /// Outputs at many points, in input order; each error carries its sample
    /// index ([`EvalError::Sample`]). The default evaluates in parallel on the
    /// current rayon pool.
    fn evaluate_batch(&self, xs: &[Vec<f64>]) -> Vec<Result<Vec<f64>, EvalError>> {
        xs.par_iter()
            .enumerate()
            .map(|(i, x)| self.evaluate(x).map_err(|e| e.at_sample(i)))
            .collect()
    }
}

/// Check the length of a point against the model's parameters.
pub fn check_dimension(model: &(impl Model + ?Sized), x: &[f64]) -> Result<(), EvalError> {
    let expected = model.parameters().len();
    if x.len() == expected {
        Ok(())
    } else {
        Err(EvalError::Dimension {
            expected,
            got: x.len(),
        })
    }
}

/// A model wrapper that counts evaluations (each point of a batch counts once).
pub struct Counted<'a, M: Model + ?Sized> {
    inner: &'a M,
    count: AtomicU64,
}

impl<'a, M: Model + ?Sized> Counted<'a, M> {
    pub fn new(inner: &'a M) -> Self {
        Counted {
            inner,
            count: AtomicU64::new(0),
        }
    }

    /// Evaluations so far (successful or not).
    pub fn evaluations(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }
}

impl<M: Model + ?Sized> Model for Counted<'_, M> {
    fn parameters(&self) -> &[Parameter] {
        self.inner.parameters()
    }
    fn outputs(&self) -> &[String] {
        self.inner.outputs()
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        self.count.fetch_add(1, Ordering::Relaxed);
        self.inner.evaluate(x)
    }
    fn evaluate_batch(&self, xs: &[Vec<f64>]) -> Vec<Result<Vec<f64>, EvalError>> {
        self.count.fetch_add(xs.len() as u64, Ordering::Relaxed);
        self.inner.evaluate_batch(xs)
    }
}

/// Evaluate all points in chunks of `chunk` (so a progress callback sees the
/// work advance), returning the outputs in input order or, if any sample
/// failed, [`EvalError::Batch`] naming the first failed sample by its index in
/// `xs`. Every output must be finite.
pub fn evaluate_all(
    model: &(impl Model + ?Sized),
    xs: &[Vec<f64>],
    chunk: usize,
    progress: &dyn Fn(u64),
) -> Result<Vec<Vec<f64>>, EvalError> {
    let n_out = model.outputs().len();
    let mut out = Vec::with_capacity(xs.len());
    let mut failed = 0;
    let mut first: Option<EvalError> = None;
    for (c, block) in xs.chunks(chunk.max(1)).enumerate() {
        let offset = c * chunk.max(1);
        for (i, r) in model.evaluate_batch(block).into_iter().enumerate() {
            let checked = r.and_then(|y| {
                if y.len() != n_out {
                    Err(EvalError::Command(format!(
                        "model returned {} outputs, expected {n_out}",
                        y.len()
                    )))
                } else if let Some(k) = y.iter().position(|v| !v.is_finite()) {
                    Err(EvalError::Domain(format!(
                        "output `{}` is {}",
                        model.outputs()[k],
                        y[k]
                    )))
                } else {
                    Ok(y)
                }
            });
            match checked {
                Ok(y) => out.push(y),
                Err(e) => {
                    failed += 1;
                    let e = match e {
                        e @ EvalError::Sample { .. } => e.at_sample(offset),
                        e => e.at_sample(offset + i),
                    };
                    if first.is_none() {
                        first = Some(e);
                    }
                }
            }
        }
        progress(block.len() as u64);
    }
    match first {
        None => Ok(out),
        Some(first) => Err(EvalError::Batch {
            failed,
            total: xs.len(),
            first: Box::new(first),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_keeps_order_and_counts() {
        let m = Ishigami::new();
        let counted = Counted::new(&m);
        let xs: Vec<Vec<f64>> = (0..50).map(|i| vec![i as f64 * 0.01, 0.2, -0.3]).collect();
        let ys = evaluate_all(&counted, &xs, 7, &|_| {}).unwrap();
        assert_eq!(counted.evaluations(), 50);
        for (x, y) in xs.iter().zip(&ys) {
            assert_eq!(y, &m.evaluate(x).unwrap());
        }
    }

    #[test]
    fn failures_name_the_sample_index() {
        let m = Ishigami::new();
        let mut xs: Vec<Vec<f64>> = (0..20).map(|_| vec![0.1, 0.2, 0.3]).collect();
        xs[13] = vec![0.1, 0.2];
        xs[17] = vec![0.1];
        let err = evaluate_all(&m, &xs, 5, &|_| {}).unwrap_err();
        assert_eq!(err.sample_index(), Some(13));
        let text = err.to_string();
        assert!(text.contains("2 of 20"), "{text}");
        assert!(text.contains("sample 13"), "{text}");
    }
}
