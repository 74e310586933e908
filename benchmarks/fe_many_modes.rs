//! Phases of one many-mode solve of an FE super-element model (issue 32):
//! what `modalflow run` spends on a synthesize stage, split into the
//! model file's parse (Matrix Market read), preparation (assembly and
//! symbolic analysis), the shift choice (its own factorization and loose
//! Lanczos, `src/dynamics/shift.rs`), the numeric factorization at the
//! chosen σ, the Lanczos, and the residual check of every mode. CPU time
//! of this thread (`/proc/thread-self/schedstat`, ns), one thread, best of
//! `reps` for the solver phases (parse and preparation run once). With
//! `OUT`, the eigenvalues (rad²/s²) and the mass-normalized shapes at every
//! DOF (column-major) of the last repetition are written there as raw
//! little-endian f64 for the subspace MAC of `fe_many_modes.py`, and the
//! whole evaluation is not timed again.
//!
//! ```sh
//! /tmp/aeenv/bin/python benchmarks/fe_many_modes.py target/release/modalflow 1 hex8,free,8,8,40,100
//! cargo bench --bench fe_many_modes -- DIR/model.yaml 100 3 [OUT]
//! ```
#![allow(non_snake_case)]

use modalflow::dynamics::lanczos::LanczosOptions;
use modalflow::dynamics::shift_invert::Workspace;
use modalflow::dynamics::PreparedModel;
use std::path::Path;

/// CPU seconds this thread has run (first field of schedstat, ns).
fn cpu() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |ns| ns * 1e-9)
}

fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t = cpu();
    let r = f();
    (cpu() - t, r)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let (file, modes, reps, out) = match &args[..] {
        [f, m, r] => (f, m, r, None),
        [f, m, r, o] => (f, m, r, Some(o)),
        _ => {
            eprintln!("usage: fe_many_modes MODEL.yaml MODES REPS [OUT]");
            std::process::exit(2);
        }
    };
    let nev: usize = modes.parse().expect("MODES: a count");
    let reps: usize = reps.parse().expect("REPS: a count");
    let path = Path::new(file);
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path.file_name().and_then(|s| s.to_str()).unwrap_or(file);
    let (t_parse, model) = timed(|| {
        modalflow::stages::params::model_files::load_model(dir, name)
            .expect("model")
            .0
    });
    let (t_prep, pm) = timed(|| PreparedModel::new(&model).expect("prepared"));
    let (t_shift, choice) = timed(|| pm.shift_choice());
    let values: Vec<f64> = pm.parameters.iter().map(|p| p.value).collect();
    let c = pm.config(0).expect("config 0");
    let options = LanczosOptions {
        block: model
            .solver
            .block
            .unwrap_or(LanczosOptions::default().block),
        ..LanczosOptions::default()
    };
    let mut ws = Workspace::default();
    let (mut t_fac, mut t_lan, mut t_res, mut t_eval) = (f64::MAX, f64::MAX, f64::MAX, f64::MAX);
    let mut top = 0.0;
    let mut bytes = Vec::new();
    for _ in 0..reps.max(1) {
        let (t, r) = timed(|| {
            pm.storage.factor(
                0,
                &c.stiffness,
                &values,
                choice.sigma,
                &mut ws,
                &pm.dof_labels,
            )
        });
        r.expect("factor");
        t_fac = t_fac.min(t);
        let (t, r) = timed(|| pm.storage.lowest(nev, choice.sigma, &options, &mut ws));
        let (lambda, Phi) = r.expect("lanczos");
        t_lan = t_lan.min(t);
        let (t, r) = timed(|| pm.check_residuals(c, &values, &lambda, &Phi, &mut ws));
        r.expect("residual check");
        t_res = t_res.min(t);
        top = lambda[nev - 1].sqrt() / (2.0 * std::f64::consts::PI);
        if out.is_some() {
            bytes.clear();
            bytes.extend(lambda.iter().flat_map(|l| l.to_le_bytes()));
            for j in 0..Phi.ncols() {
                bytes.extend(Phi.col(j).iter().flat_map(|x| x.to_le_bytes()));
            }
            continue;
        }
        let (t, r) = timed(|| pm.evaluate(0, &values, nev));
        r.expect("evaluate");
        t_eval = t_eval.min(t);
    }
    if let Some(path) = out {
        std::fs::write(path, &bytes).expect("write OUT");
    }
    println!(
        "DOF {} modes {nev} (top {top:.0} Hz) sigma {:.4e} rigid {} nnz(K_sigma) {} nnz(L) {}",
        pm.n_dofs(),
        choice.sigma,
        choice.rigid_body_modes,
        pm.storage.nnz().0,
        pm.storage.nnz().1
    );
    println!(
        "CPU s: parse {t_parse:.3}  prepare {t_prep:.3}  shift choice {t_shift:.3}  factor {t_fac:.3}  \
         lanczos {t_lan:.3}  residual check {t_res:.3}  (one evaluate {t_eval:.3})"
    );
}
