//! Timing helpers shared by the bench binaries: best-of-n wall time and a
//! rayon pool of a given size (each bench compares thread counts or a
//! reference in the same process, so the figures are ratios).

#![allow(dead_code)]

use std::hint::black_box;
use std::time::Instant;

/// Best wall time of `reps` calls of `f`, in seconds, and the last result.
pub fn best<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("reps >= 1"))
}

/// A rayon pool with `threads` worker threads.
pub fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}
