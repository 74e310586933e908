//! In-process fuzzing on the stable toolchain: a time-boxed mutation
//! harness over the UFF reader, the CSV FRF reader, the model-file parser
//! and the pipeline parser with its whole validation
//! (`benchmarks/fuzz_targets.rs`). Seeds come from the fixtures and
//! `tests/fuzz/corpus/<target>/`; inputs with a new outcome class join the
//! corpus (a few are saved there), and any input that panics or takes over
//! a second is saved to `tests/fuzz/crashers/<target>/`, which the
//! regression test in `tests/reliability.rs` replays.
//!
//! ```sh
//! cargo bench --bench fuzz -- [--target uff|csv_frf|model|pipeline] \
//!     [--seconds 60] [--execs 10000000] [--seed 1]
//! ```

#[path = "fuzz_targets.rs"]
mod fuzz_targets;

use fuzz_targets::{mutate, seeds, targets, Rng, Target};
use std::collections::HashSet;
use std::path::Path;
use std::time::{Duration, Instant};

/// Largest in-memory corpus (inputs are mutated from it uniformly).
const MAX_CORPUS: usize = 4096;

struct Options {
    target: Option<String>,
    seconds: f64,
    execs: u64,
    seed: u64,
}

fn options() -> Options {
    let mut o = Options {
        target: None,
        seconds: 10.0,
        execs: u64::MAX,
        seed: 1,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--target" => o.target = Some(value),
            "--seconds" => o.seconds = value.parse().unwrap_or(o.seconds),
            "--execs" => o.execs = value.parse().unwrap_or(o.execs),
            "--seed" => o.seed = value.parse().unwrap_or(o.seed),
            // `cargo bench` passes `--bench`.
            _ => {
                i += 1;
                continue;
            }
        }
        i += 2;
    }
    o
}

struct Outcome {
    execs: u64,
    classes: usize,
    corpus: usize,
    crashes: usize,
    slow: usize,
    seconds: f64,
}

fn save(dir: &Path, data: &[u8], suffix: &str) {
    let _ = std::fs::create_dir_all(dir);
    let name = format!("{}{suffix}", &blake3::hash(data).to_hex()[..16]);
    let _ = std::fs::write(dir.join(name), data);
}

fn fuzz(root: &Path, t: &Target, o: &Options) -> Outcome {
    let mut corpus = seeds(root, t);
    corpus.extend(seeds_from(&root.join("tests/fuzz/corpus").join(t.name)));
    corpus.sort();
    corpus.dedup();
    if corpus.is_empty() {
        corpus.push(Vec::new());
    }
    let crash_dir = root.join("tests/fuzz/crashers").join(t.name);
    let keep_dir = root.join("tests/fuzz/corpus").join(t.name);
    let mut classes: HashSet<String> = corpus.iter().map(|c| (t.run)(c)).collect();
    let mut rng = Rng(o.seed ^ blake3::hash(t.name.as_bytes()).as_bytes()[0] as u64);
    let (start, limit) = (Instant::now(), Duration::from_secs_f64(o.seconds));
    let mut out = Outcome {
        execs: 0,
        classes: 0,
        corpus: 0,
        crashes: 0,
        slow: 0,
        seconds: 0.0,
    };
    let mut saved = 0;
    while out.execs < o.execs && (!out.execs.is_multiple_of(256) || start.elapsed() < limit) {
        let a = rng.below(corpus.len());
        let b = rng.below(corpus.len());
        let input = mutate(&mut rng, &corpus[a], &corpus[b]);
        let t0 = Instant::now();
        let result = std::panic::catch_unwind(|| (t.run)(&input));
        out.execs += 1;
        if t0.elapsed() > Duration::from_secs(1) {
            out.slow += 1;
            save(&crash_dir, &input, ".slow");
        }
        match result {
            Err(_) => {
                out.crashes += 1;
                save(&crash_dir, &input, "");
            }
            Ok(class) => {
                if classes.insert(class) && corpus.len() < MAX_CORPUS {
                    if saved < 25 && input.len() < 8192 {
                        save(&keep_dir, &input, "");
                        saved += 1;
                    }
                    corpus.push(input);
                }
            }
        }
    }
    out.classes = classes.len();
    out.corpus = corpus.len();
    out.seconds = start.elapsed().as_secs_f64();
    out
}

fn seeds_from(dir: &Path) -> Vec<Vec<u8>> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .collect();
    files.sort();
    files.iter().filter_map(|f| std::fs::read(f).ok()).collect()
}

fn main() {
    let o = options();
    // Panics are findings, counted and saved; their messages would drown
    // the summary.
    std::panic::set_hook(Box::new(|_| {}));
    // As `--max-memory 256M`: a mutated size that validation accepts then
    // allocates; keep each input's work small (over a second is recorded).
    modalflow::resources::set_memory_limit(256 << 20);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    println!("target      executions   exec/s   classes  corpus  crashes  slow");
    for t in targets() {
        if o.target.as_deref().is_some_and(|n| n != t.name) {
            continue;
        }
        let r = fuzz(root, &t, &o);
        println!(
            "{:<10} {:>11} {:>8.0} {:>9} {:>7} {:>8} {:>5}",
            t.name,
            r.execs,
            r.execs as f64 / r.seconds,
            r.classes,
            r.corpus,
            r.crashes,
            r.slow
        );
    }
    fuzz_targets::cleanup();
}
