//! Development harness: the guided identification over a family of
//! perturbation seeds from exact modes (scenario 1 of PUB3).
//!
//! Run: `cargo bench --bench identification_families -- <subproblems.json> <seeds> [budget]`
#![allow(clippy::unwrap_used)]

use modalflow::dynamics::measurement::GaussianStream;
use modalflow::dynamics::{ModeSelection, Model, PreparedModel};
use modalflow::identify::{
    self, GuidedParams, ModalObjective, Plan, Screening, Strategy, SubproblemSpec, Weights,
};
use modalflow::metrics::mac;
use modalflow::modal::ModalModel;
use modalflow::pairing::{pair_modes, Pairing};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().filter(|a| a != "--bench").collect();
    let subs_path = &args[1];
    let seeds: Vec<u64> = args[2].split(',').map(|s| s.parse().unwrap()).collect();
    let budget: usize = args.get(3).map_or(6000, |s| s.parse().unwrap());
    let text = std::fs::read_to_string("pipelines/models/uniaxial_test_bench.yaml").unwrap();
    let read = |p: &str| std::fs::read(format!("pipelines/models/{p}"));
    let model = Model::from_yaml(&text, "uniaxial_test_bench.yaml", &read).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(subs_path).unwrap()).unwrap();
    let specs: Vec<SubproblemSpec> = serde_json::from_value(json["subproblems"].clone()).unwrap();
    let significant: Vec<String> = serde_json::from_value(json["significant"].clone()).unwrap();
    let prepared = PreparedModel::new(&model).unwrap();
    for seed in seeds {
        let mut x = model.true_values();
        for (i, p) in model.parameters.iter().enumerate() {
            if !significant.contains(&p.name) {
                continue;
            }
            let g = GaussianStream::new(seed, i as u64).standard();
            x[i] = (p.value * (0.3 * g).exp()).clamp(p.lower, p.upper);
        }
        let reference: Vec<ModalModel> = [0usize, 3]
            .iter()
            .map(|&c| {
                let sol = prepared
                    .evaluate_modes(c, &x, ModeSelection::Below(400.0))
                    .unwrap();
                let mut m = prepared.modal_model(&sol).unwrap();
                m.modes
                    .retain(|m| m.frequency_hz >= 10.0 && m.frequency_hz <= 200.0);
                m
            })
            .collect();
        let mode = std::env::var("MODE").unwrap_or_default();
        if mode == "band" {
            band(&model, &reference, &significant, &x, budget);
            continue;
        }
        let measured: Vec<ModalModel> = match std::env::var("REF") {
            Ok(pattern) => {
                let dir = pattern.replace("{s}", &seed.to_string());
                modalflow::stages::artifacts::read_modes(std::path::Path::new(&dir), "reference")
                    .unwrap()
            }
            Err(_) => reference.clone(),
        };
        let window: f64 = std::env::var("WINDOW")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.3);
        let min_mac: f64 = std::env::var("MINMAC")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.0);
        let mut o = ModalObjective::new(
            &model,
            &measured,
            None,
            Weights::default(),
            Pairing {
                window,
                min_mac,
                ..Pairing::default()
            },
        )
        .unwrap();
        o.set_uncertainty(Default::default());
        let t = Instant::now();
        let settings = GuidedParams {
            repeats: std::env::var("REPEATS")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(3),
            ..GuidedParams::default()
        };
        let slsqp = Default::default();
        let named: Vec<modalflow::identify::NamedMode> =
            serde_json::from_value(json["modes"].clone()).unwrap_or_default();
        let plan = Plan {
            strategy: Strategy::Guided {
                screening: Screening {
                    specs: &specs,
                    significant: Some(&significant),
                    modes: &named,
                },
                settings: &settings,
                slsqp: &slsqp,
            },
            budget,
            seed: 1,
            visibility: 0.25,
            exclude: &[],
            max_std_error: 0.1,
        };
        let u = identify::update(&mut o, &plan, &|_| {}).unwrap();
        let secs = t.elapsed().as_secs_f64();
        let ident: Vec<bool> = model
            .parameters
            .iter()
            .enumerate()
            .map(|(i, _)| {
                u.identified
                    .iter()
                    .position(|&k| k == i)
                    .map_or(false, |j| u.identifiability.parameters[j].identifiable)
            })
            .collect();
        let mut errs: Vec<f64> = model
            .parameters
            .iter()
            .enumerate()
            .filter(|(i, p)| {
                significant.contains(&p.name)
                    && p.kind == modalflow::dynamics::ParameterKind::Stiffness
                    && ident[*i]
            })
            .map(|(i, _)| (u.x[i] / x[i] - 1.0).abs())
            .collect();
        errs.sort_by(f64::total_cmp);
        let n_ident = errs.len();
        let upd = o.model_modes(&u.x).unwrap();
        let mut macs = Vec::new();
        for (rm, um) in reference.iter().zip(&upd) {
            let s = rm.shared_shapes(um);
            let rf: Vec<f64> = rm.modes.iter().map(|m| m.frequency_hz).collect();
            let uf: Vec<f64> = um.modes.iter().map(|m| m.frequency_hz).collect();
            let pairs = pair_modes(&rf, &s.first, &uf, &s.second, &Pairing::within(0.1));
            if std::env::var("MACS").is_ok() {
                let line: Vec<String> = (0..rf.len())
                    .map(|k| {
                        let pm = pairs.iter().find(|p| p.reference == k);
                        format!("{:.1}:{:.3}", rf[k], pm.map_or(0.0, |p| p.mac))
                    })
                    .collect();
                println!("   true-mode MAC: {}", line.join(" "));
            }
            for k in 0..rf.len() {
                macs.push(
                    pairs
                        .iter()
                        .find(|p| p.reference == k)
                        .map_or(0.0, |p| mac(&s.first[k], &s.second[p.candidate])),
                );
            }
        }
        let mean_mac = macs.iter().sum::<f64>() / macs.len() as f64;
        if std::env::var("PARAMS").is_ok() {
            for (j, &i) in u.identified.iter().enumerate() {
                let a = &u.identifiability.parameters[j];
                println!(
                    "   {:14} err {:9.2e} start {:9.2e} prior_se {:9.2e} post {:?}",
                    a.parameter,
                    u.x[i] / x[i] - 1.0,
                    u.start[i] / x[i] - 1.0,
                    a.prior_std_error,
                    a.std_error
                );
            }
            println!(
                "   sv: {:?} var {:?}",
                u.identifiability
                    .singular_values
                    .iter()
                    .map(|v| format!("{v:.1e}"))
                    .collect::<Vec<_>>(),
                u.identifiability.residual_variance
            );
        }
        let g = u.guided.as_ref().unwrap();
        if std::env::var("PARAMS").is_ok() {
            println!("   verdict: {} {:?}", u.verdict.message, u.verdict.warnings);
        }
        if std::env::var("RUNS").is_ok() {
            for r in &g.refinement {
                let st: Vec<String> = r
                    .stages
                    .iter()
                    .map(|s| {
                        format!(
                            "{}:{:.2e}->{:.2e}({},{})",
                            s.modes, s.start, s.end, s.evaluations, s.termination
                        )
                    })
                    .collect();
                println!(
                    "   run {} {:.3e}->{:.3e}: {}",
                    r.from,
                    r.start,
                    r.end,
                    st.join(" ")
                );
            }
        }
        println!(
            "seed {seed:3} n_ref {} used {} unp {} ok {} rms {:.2e}->{:.2e} med_err {:.5} max {:.4} n_ident {n_ident} mac {:.6} evals {} [{}] runs {} {:.0}s | {}",
            u.verdict.modes.reference, u.verdict.modes.used, u.verdict.modes.unpaired, u.verdict.ok, u.verdict.start_rms, u.verdict.end_rms,
            errs[errs.len() / 2],
            errs[errs.len() - 1],
            mean_mac,
            u.evaluations,
            g.phase_evaluations.map(|v| v.to_string()).join("/"),
            g.refinement.len(),
            secs,
            u.identifiability.undetermined.iter().map(|c| c.describe()).collect::<Vec<_>>().join(" ; ")
        );
        continue;
    }
}

fn multistart(
    o: &ModalObjective,
    model: &Model,
    significant: &[String],
    truth: &[f64],
    budget: usize,
    _seed: u64,
) {
    use modalflow::optimize::levenberg_marquardt::{minimize, LmParams};
    use modalflow::optimize::Bounds;
    use rayon::prelude::*;
    let idx: Vec<usize> = model
        .parameters
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            significant.contains(&p.name) && p.kind == modalflow::dynamics::ParameterKind::Stiffness
        })
        .map(|(i, _)| i)
        .collect();
    let full = o.bounds().unwrap();
    let bounds = Bounds::new(
        idx.iter().map(|&i| full.lower()[i]).collect(),
        idx.iter().map(|&i| full.upper()[i]).collect(),
        idx.iter().map(|&i| full.scale()[i]).collect(),
    )
    .unwrap();
    let base = o.nominal();
    let point = |v: &[f64]| {
        let mut p = base.clone();
        for (j, &i) in idx.iter().enumerate() {
            p[i] = v[j];
        }
        p
    };
    let res = |pts: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        pts.par_iter()
            .map(|p| o.evaluate(&point(p), &o.usable()).map(|r| r.residuals))
            .collect()
    };
    let starts: usize = std::env::var("STARTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    let per = budget / starts;
    let width: f64 = std::env::var("WIDTH")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let u0 = bounds.to_unit(&idx.iter().map(|&i| base[i]).collect::<Vec<_>>());
    for k in 0..starts {
        let u: Vec<f64> = (0..idx.len())
            .map(|d| {
                if k == 0 {
                    u0[d]
                } else {
                    let s = sobol_burley::sample(k as u32, d as u32, 7);
                    (u0[d] + width * (s as f64 - 0.5)).clamp(0.0, 1.0)
                }
            })
            .collect();
        let x0 = bounds.to_physical(&u);
        let r = minimize(&bounds, &res, &x0, per, &LmParams::default()).unwrap();
        let xf = point(&r.x_best);
        let mut errs: Vec<f64> = idx
            .iter()
            .map(|&i| (xf[i] / truth[i] - 1.0).abs())
            .collect();
        errs.sort_by(f64::total_cmp);
        if std::env::var("DETAIL").is_ok() {
            for (label, xx) in [
                ("start", point(&x0)),
                ("end", xf.clone()),
                ("truth", truth.to_vec()),
            ] {
                let m = o.matches(&xx).unwrap();
                let line: Vec<String> = m
                    .iter()
                    .enumerate()
                    .flat_map(|(p, ms)| ms.iter().enumerate().map(move |(r, mm)| (p, r, *mm)))
                    .map(|(p, r, mm)| match mm {
                        Some(mm) => format!(
                            "{:.1}/{:.1}:{:.2}",
                            o.reference_frequency(p, r),
                            mm.frequency_hz,
                            mm.mac
                        ),
                        None => format!("{:.1}/-", o.reference_frequency(p, r)),
                    })
                    .collect();
                println!("     {label}: {}", line.join(" "));
            }
        }
        println!(
            "   start {k:2} cost {:.3e} -> {:.3e} med_err {:.4} evals {} {:?}",
            r.history[0].f_best,
            r.cost,
            errs[errs.len() / 2],
            r.evaluations,
            r.termination
        );
    }
}

fn track(prepared: &PreparedModel, x0: &[f64], x1: &[f64]) {
    use faer::Mat;
    for &c in &[0usize, 3] {
        let steps = 100;
        let n = 16;
        let sol0 = prepared.evaluate(c, x0, n).unwrap();
        let f0 = sol0.frequencies_hz();
        // perm[k] = current index of nominal mode k
        let mut perm: Vec<usize> = (0..n).collect();
        let mut prev: Mat<f64> = sol0.Phi.clone();
        let mut sol = sol0.clone();
        for s in 1..=steps {
            let t = s as f64 / steps as f64;
            let x: Vec<f64> = x0
                .iter()
                .zip(x1)
                .map(|(a, b)| a * (b / a).powf(t))
                .collect();
            sol = prepared.evaluate(c, &x, n + 4).unwrap();
            let mut newperm = vec![0; n];
            for k in 0..n {
                let a = prev.col(perm[k]);
                let mut best = (0, -1.0);
                for j in 0..sol.Phi.ncols() {
                    let b = sol.Phi.col(j);
                    let d: f64 = (0..a.nrows()).map(|i| a[i] * b[i]).sum();
                    let na: f64 = (0..a.nrows()).map(|i| a[i] * a[i]).sum();
                    let nb: f64 = (0..a.nrows()).map(|i| b[i] * b[i]).sum();
                    let m = d * d / (na * nb);
                    if m > best.1 {
                        best = (j, m);
                    }
                }
                newperm[k] = best.0;
            }
            perm = newperm;
            prev = sol.Phi.clone();
        }
        let f1 = sol.frequencies_hz();
        let line: Vec<String> = (0..12)
            .map(|k| {
                format!(
                    "{}:{:.1}->#{}:{:.1}",
                    k + 1,
                    f0[k],
                    perm[k] + 1,
                    f1[perm[k]]
                )
            })
            .collect();
        println!("  pos {c}: {}", line.join("  "));
    }
}

fn oracle(
    prepared: &PreparedModel,
    model: &Model,
    significant: &[String],
    truth: &[f64],
    budget: usize,
) {
    use modalflow::optimize::levenberg_marquardt::{minimize, LmParams};
    use modalflow::optimize::Bounds;
    use rayon::prelude::*;
    let idx: Vec<usize> = model
        .parameters
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            significant.contains(&p.name) && p.kind == modalflow::dynamics::ParameterKind::Stiffness
        })
        .map(|(i, _)| i)
        .collect();
    let p = &model.parameters;
    let bounds = Bounds::new(
        idx.iter().map(|&i| p[i].lower).collect(),
        idx.iter().map(|&i| p[i].upper).collect(),
        idx.iter()
            .map(|_| modalflow::optimize::Scale::Log10)
            .collect(),
    )
    .unwrap();
    let base = model.true_values();
    let point = |v: &[f64]| {
        let mut q = base.clone();
        for (j, &i) in idx.iter().enumerate() {
            q[i] = v[j];
        }
        q
    };
    let refs: Vec<(usize, modalflow::dynamics::ModalSolution, Vec<usize>)> = [0usize, 3]
        .iter()
        .map(|&c| {
            let sol = prepared.evaluate(c, truth, 14).unwrap();
            let f = sol.frequencies_hz();
            let keep: Vec<usize> = (0..f.len())
                .filter(|&k| {
                    f[k] >= 10.0
                        && f[k] <= 200.0
                        && !((c == 0 && (k == 6 || k == 7)) || (c == 3 && k == 7))
                })
                .collect();
            (c, sol, keep)
        })
        .collect();
    let res = |pts: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
        pts.par_iter()
            .map(|v| {
                let x = point(v);
                let mut out = Vec::new();
                for (c, rs, keep) in &refs {
                    let sol = prepared.evaluate(*c, &x, 16).ok()?;
                    let f = sol.frequencies_hz();
                    let fr = rs.frequencies_hz();
                    for &k in keep {
                        let a = rs.Phi.col(k);
                        let mut best = (0, -1.0);
                        for j in 0..sol.Phi.ncols() {
                            let b = sol.Phi.col(j);
                            let d: f64 = (0..a.nrows()).map(|i| a[i] * b[i]).sum();
                            let na: f64 = (0..a.nrows()).map(|i| a[i] * a[i]).sum();
                            let nb: f64 = (0..a.nrows()).map(|i| b[i] * b[i]).sum();
                            let m = d * d / (na * nb);
                            if m > best.1 {
                                best = (j, m);
                            }
                        }
                        let j = best.0;
                        out.push((f[j] - fr[k]) / fr[k]);
                        let ra: Vec<f64> = (0..10).map(|i| rs.sensor_shapes[(i, k)]).collect();
                        let rb: Vec<f64> = (0..10).map(|i| sol.sensor_shapes[(i, j)]).collect();
                        let na = ra.iter().map(|v| v * v).sum::<f64>().sqrt();
                        let nb = rb.iter().map(|v| v * v).sum::<f64>().sqrt();
                        let sg = if ra.iter().zip(&rb).map(|(a, b)| a * b).sum::<f64>() >= 0.0 {
                            1.0
                        } else {
                            -1.0
                        };
                        for i in 0..10 {
                            out.push(sg * rb[i] / nb - ra[i] / na);
                        }
                    }
                }
                Some(out)
            })
            .collect()
    };
    let x0: Vec<f64> = idx.iter().map(|&i| base[i]).collect();
    let r = minimize(&bounds, &res, &x0, budget, &LmParams::default()).unwrap();
    let xf = point(&r.x_best);
    let mut errs: Vec<f64> = idx
        .iter()
        .map(|&i| (xf[i] / truth[i] - 1.0).abs())
        .collect();
    errs.sort_by(f64::total_cmp);
    println!(
        "   oracle cost {:.3e} -> {:.3e} med_err {:.4} max {:.3} evals {} {:?}",
        r.history[0].f_best,
        r.cost,
        errs[errs.len() / 2],
        errs[errs.len() - 1],
        r.evaluations,
        r.termination
    );
}

fn band(
    model: &Model,
    reference: &[ModalModel],
    significant: &[String],
    truth: &[f64],
    budget: usize,
) {
    use modalflow::optimize::levenberg_marquardt::{minimize, LmParams};
    use modalflow::optimize::Bounds;
    use rayon::prelude::*;
    let idx: Vec<usize> = model
        .parameters
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            significant.contains(&p.name) && p.kind == modalflow::dynamics::ParameterKind::Stiffness
        })
        .map(|(i, _)| i)
        .collect();
    let p = &model.parameters;
    let bounds = Bounds::new(
        idx.iter().map(|&i| p[i].lower).collect(),
        idx.iter().map(|&i| p[i].upper).collect(),
        idx.iter()
            .map(|_| modalflow::optimize::Scale::Log10)
            .collect(),
    )
    .unwrap();
    let mut base = model.true_values();
    let cuts: Vec<f64> = std::env::var("COUNTS")
        .unwrap_or("2,3,4,5,6,7,8,9,10,11,99".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let window: f64 = std::env::var("WINDOW")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.3);
    for cut in cuts {
        let refs: Vec<ModalModel> = reference
            .iter()
            .map(|r| {
                let mut r = r.clone();
                r.modes
                    .retain(|m| !(m.frequency_hz > 84.40 && m.frequency_hz < 84.47));
                r.modes.truncate(cut as usize);
                r
            })
            .collect();
        let o = ModalObjective::new(
            model,
            &refs,
            None,
            Weights::default(),
            Pairing::within(window),
        )
        .unwrap();
        let point = |v: &[f64]| {
            let mut q = base.clone();
            for (j, &i) in idx.iter().enumerate() {
                q[i] = v[j];
            }
            q
        };
        let res = |pts: &[Vec<f64>]| -> Vec<Option<Vec<f64>>> {
            pts.par_iter()
                .map(|v| o.evaluate(&point(v), &o.usable()).map(|r| r.residuals))
                .collect()
        };
        let x0: Vec<f64> = idx.iter().map(|&i| base[i]).collect();
        let ftol: f64 = std::env::var("FTOL")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1e-10);
        let max_step: f64 = std::env::var("MAXSTEP")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.05);
        let lp = LmParams {
            ftol: if cut < 98.0 { ftol } else { 1e-10 },
            max_step,
            ..LmParams::default()
        };
        let r = minimize(&bounds, &res, &x0, budget / 4, &lp).unwrap();
        if std::env::var("HIST").is_ok() {
            let h: Vec<String> = r
                .history
                .iter()
                .map(|h| format!("{}:{:.1e}", h.evaluation, h.f_best))
                .collect();
            println!("     {}", h.join(" "));
        }
        base = point(&r.x_best);
        let mut errs: Vec<f64> = idx
            .iter()
            .map(|&i| (base[i] / truth[i] - 1.0).abs())
            .collect();
        errs.sort_by(f64::total_cmp);
        println!(
            "   cut {cut} modes {} cost {:.3e} -> {:.3e} med_err {:.4} max {:.3} evals {} {:?}",
            o.reference_modes(),
            r.history[0].f_best,
            r.cost,
            errs[errs.len() / 2],
            errs[errs.len() - 1],
            r.evaluations,
            r.termination
        );
    }
}
