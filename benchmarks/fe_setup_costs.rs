//! What an FE super-element costs before the solve (issue 32), timed here
//! rather than in the test suite:
//!
//! - `fill`: the symbolic Cholesky count of nnz(L) behind the memory
//!   estimate (`dynamics::fill`), exact and on the FE-node graph, on the
//!   patterns of hex8 columns and cubes of ~50k and ~190k DOF; CPU seconds
//!   of this thread (docs/fe-models.md, "Memory").
//! - `read FILE…`: the Matrix Market reader alone on exported files (file
//!   read and parse); `benchmarks/fe_by_reference.py` times this process
//!   against scipy's `mmread` (docs/fe-models.md, "Large matrices by
//!   reference").
//!
//! `cargo bench --bench fe_setup_costs -- fill`
//! `cargo bench --bench fe_setup_costs -- read k.mtx m.mtx`

use modalflow::dynamics::fill::{cholesky_factor_nnz, cholesky_factor_nnz_by_nodes};
use modalflow::dynamics::sparse::Csc;
use modalflow::io::fe::read_matrix_market;

/// The stiffness pattern of a regular hex8 mesh of `e` elements per
/// direction (3 DOFs per node, every node coupled to its 27 neighbours).
fn hex8_pattern([ex, ey, ez]: [usize; 3]) -> Csc {
    let (gx, gy, gz) = (ex + 1, ey + 1, ez + 1);
    let id = |x: usize, y: usize, z: usize| x + gx * (y + gy * z);
    let near = |c: usize, g: usize| c.saturating_sub(1)..(c + 2).min(g);
    let mut t = Vec::new();
    for (x, y, z) in
        (0..gz).flat_map(|z| (0..gy).flat_map(move |y| (0..gx).map(move |x| (x, y, z))))
    {
        for (xx, yy, zz) in near(z, gz)
            .flat_map(|zz| near(y, gy).flat_map(move |yy| near(x, gx).map(move |xx| (xx, yy, zz))))
        {
            for (a, b) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
                t.push((3 * id(x, y, z) + a, 3 * id(xx, yy, zz) + b, 1.0));
            }
        }
    }
    Csc::from_triplets(3 * gx * gy * gz, t)
}

/// CPU seconds of this thread so far (/proc/thread-self/schedstat, ns).
fn cpu() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

fn fill() {
    for e in [[12, 12, 100], [20, 20, 150], [24, 24, 24], [39, 39, 39]] {
        let k = hex8_pattern(e);
        let t = cpu();
        let nnz = cholesky_factor_nnz(&k, &k).expect("symbolic analysis");
        let exact = cpu() - t;
        let t = cpu();
        let by_nodes = cholesky_factor_nnz_by_nodes(&k, &k).expect("symbolic analysis");
        let quick = cpu() - t;
        println!(
            "hex8 {e:?}: n = {}, nnz(K) = {}, nnz(L) = {nnz} (fill {:.2}) in {exact:.3} CPU-s; \
             by nodes {by_nodes} ({:+.2} %) in {quick:.3} CPU-s",
            k.n,
            k.nnz(),
            nnz as f64 / k.nnz() as f64,
            100.0 * (by_nodes as f64 / nnz as f64 - 1.0)
        );
    }
}

fn read(files: &[String]) {
    for path in files {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let m = read_matrix_market(&text).unwrap_or_else(|e| panic!("{path}: {e}"));
        println!("{path}: {} rows, {} entries", m.n, m.entries.len());
    }
}

fn main() {
    // `cargo bench` passes `--bench` first; the mode follows it.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    match args.first().map(String::as_str) {
        Some("fill") => fill(),
        Some("read") => read(&args[1..]),
        _ => eprintln!("usage: fe_setup_costs fill | read FILE..."),
    }
}
