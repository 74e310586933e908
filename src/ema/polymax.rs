//! PolyMAX, the poly-reference least-squares complex frequency-domain
//! estimator (Guillaume et al. 2003, "A poly-reference implementation of the
//! least-squares complex frequency-domain estimator", IMAC XXI; Peeters et al.
//! 2004, "The PolyMAX frequency-domain method", Shock Vib. 11,
//! doi:10.1155/2004/523692).
//!
//! Right matrix-fraction model per output o, with the z-domain basis
//! Ω_f = exp(jω_f Δt), Δt = 1/(2 f_max):
//!
//! H_o(ω) = N_o(ω) D(ω)⁻¹,  N_o = Σ_r Ω_fʳ β_{o,r} (1 × n_ref),
//! D = Σ_r Ω_fʳ α_r (n_ref × n_ref, real coefficients).
//!
//! The weighted linearized equation error gives per output the real normal
//! blocks R_o = Re(X_oᴴX_o), S_o = Re(X_oᴴY_o), T_o = Re(Y_oᴴY_o); the
//! numerators are eliminated: M = 2 Σ_o (T_o − S_oᵀ R_o⁻¹ S_o) (Peeters eq. 10),
//! and α_n = I fixes the scale, α_{0..n−1} = −M_aa⁻¹ M_ab.
//!
//! Structure reused across orders: the blocks of order n are the leading
//! sub-blocks of those of the maximum order, the Cholesky factor of a leading
//! block of R_o is the leading block of its factor, and so the row k of
//! G_o = L_o⁻¹ S_o does not depend on the order. Hence
//! M(n) = 2 (Σ_o T_o − Σ_{k≤n} Σ_o g_{o,k}ᵀ g_{o,k}) restricted to its leading
//! (n+1)·n_ref block: one rank-update per order instead of a rebuild. The
//! blocks are Toeplitz in the power of z and come from 2n+1 kernel sums.
//!
//! Poles are the eigenvalues of the block companion matrix of the
//! transposed denominator, s = ln(z)/Δt; its eigenvectors start with the
//! participation factors (left null vectors of D(z_r)).

#![allow(non_snake_case)]

use super::{EmaError, FrfData};
use crate::dense::{backward_substitute_t, cholesky, forward_substitute};
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Tuning of [`polymax`].
#[derive(Clone, Debug, PartialEq)]
pub struct PolymaxParams {
    /// Highest denominator order n; each order gives n · n_ref poles.
    pub max_order: usize,
}

impl Default for PolymaxParams {
    fn default() -> Self {
        PolymaxParams { max_order: 40 }
    }
}

/// One physical pole (positive imaginary part) of one model order.
#[derive(Clone, Debug, PartialEq)]
pub struct Pole {
    /// Continuous-time pole s = −ζω + jω√(1−ζ²) in rad/s.
    pub s: Complex64,
    /// Undamped natural frequency |s|/2π in Hz.
    pub frequency_hz: f64,
    /// Damping ratio −Re(s)/|s|.
    pub damping_ratio: f64,
    /// Participation factor over the references, unit norm, phase fixed so
    /// that its largest entry is real positive.
    pub participation: Vec<Complex64>,
}

/// The poles of one model order, sorted by frequency.
#[derive(Clone, Debug, PartialEq)]
pub struct PoleOrder {
    pub order: usize,
    pub poles: Vec<Pole>,
}

/// Sampling time of the z-domain basis: the band edge maps to z = −1.
fn sampling_time(data: &FrfData) -> f64 {
    let f_max = data.frequencies_hz.iter().cloned().fold(0.0, f64::max);
    1.0 / (2.0 * f_max)
}

/// Real normal blocks of one output for order n (Toeplitz in the power of z).
struct Blocks {
    /// (n+1) × (n+1)
    R: Vec<f64>,
    /// (n+1) × (n+1)·n_ref
    S: Vec<f64>,
    /// (n+1)·n_ref square
    T: Vec<f64>,
}

/// z_f^k for k = 0..=n, k-major.
fn powers(data: &FrfData, n: usize, dt: f64) -> Vec<Complex64> {
    let nf = data.n_lines();
    let mut z = Vec::with_capacity((n + 1) * nf);
    for k in 0..=n {
        for &f in &data.frequencies_hz {
            z.push(Complex64::from_polar(1.0, 2.0 * PI * f * dt * k as f64));
        }
    }
    z
}

/// The kernel sums of output `o` and the normal blocks of order `n` they fill.
fn blocks(data: &FrfData, o: usize, n: usize, zk: &[Complex64]) -> Blocks {
    let (nf, nr) = (data.n_lines(), data.n_ref());
    // A whitened h = u·H ([`super::whitening`]) is fitted as H with u in the
    // equation-error weight: u·w_o·(N − H D).
    let u = &data.line_weight;
    let q: Vec<f64> = data.weight[o * nf..(o + 1) * nf]
        .iter()
        .zip(u)
        .map(|(w, u)| (w * u) * (w * u))
        .collect();
    let raw: Vec<Vec<Complex64>> = (0..nr)
        .map(|i| {
            data.channel(o, i)
                .iter()
                .zip(u)
                .map(|(h, u)| h / u)
                .collect()
        })
        .collect();
    let h: Vec<&[Complex64]> = raw.iter().map(Vec::as_slice).collect();
    // c[k] = Σ q z^k (real part), s_i[±k] = Σ q z^{±k} H_i, t_ij[k] = Σ q z^k H_i* H_j.
    let mut c = vec![0.0; n + 1];
    let mut s_pos = vec![Complex64::new(0.0, 0.0); nr * (n + 1)];
    let mut s_neg = s_pos.clone();
    let mut t = vec![Complex64::new(0.0, 0.0); nr * nr * (n + 1)];
    let p: Vec<Vec<Complex64>> = (0..nr * nr)
        .map(|ij| {
            let (i, j) = (ij / nr, ij % nr);
            (0..nf).map(|f| h[i][f].conj() * h[j][f] * q[f]).collect()
        })
        .collect();
    for k in 0..=n {
        let z = &zk[k * nf..(k + 1) * nf];
        c[k] = (0..nf).map(|f| q[f] * z[f].re).sum();
        for i in 0..nr {
            let (mut a, mut b) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
            for f in 0..nf {
                let qh = h[i][f] * q[f];
                a += z[f] * qh;
                b += z[f].conj() * qh;
            }
            s_pos[i * (n + 1) + k] = a;
            s_neg[i * (n + 1) + k] = b;
        }
        for ij in 0..nr * nr {
            t[ij * (n + 1) + k] = (0..nf).map(|f| z[f] * p[ij][f]).sum();
        }
    }
    let (n1, m) = (n + 1, (n + 1) * nr);
    let mut R = vec![0.0; n1 * n1];
    let mut S = vec![0.0; n1 * m];
    let mut T = vec![0.0; m * m];
    for r in 0..n1 {
        for s in 0..n1 {
            R[r * n1 + s] = c[r.abs_diff(s)];
            for i in 0..nr {
                // X_oᴴY_o: conj(w z^r)·(−w z^s H_i) = −q z^{s−r} H_i.
                let v = if s >= r {
                    s_pos[i * n1 + (s - r)]
                } else {
                    s_neg[i * n1 + (r - s)]
                };
                S[r * m + s * nr + i] = -v.re;
                for j in 0..nr {
                    // Y_oᴴY_o: q z^{s−r} H_i* H_j; negative powers by conjugate symmetry.
                    let v = if s >= r {
                        t[(i * nr + j) * n1 + (s - r)]
                    } else {
                        t[(j * nr + i) * n1 + (r - s)].conj()
                    };
                    T[(r * nr + i) * m + s * nr + j] = v.re;
                }
            }
        }
    }
    Blocks { R, S, T }
}

/// Cholesky with one retry on a tiny ridge (relative 1e-12 of the largest
/// diagonal entry) for numerically semidefinite blocks of clean data.
fn factor(a: &[f64], n: usize, order: usize) -> Result<Vec<f64>, EmaError> {
    let mut l = a.to_vec();
    if cholesky(&mut l, n) {
        return Ok(l);
    }
    let ridge = 1e-12 * (0..n).map(|i| a[i * n + i].abs()).fold(0.0, f64::max);
    let mut l = a.to_vec();
    for i in 0..n {
        l[i * n + i] += ridge;
    }
    if cholesky(&mut l, n) {
        Ok(l)
    } else {
        Err(EmaError::IllConditioned { order })
    }
}

fn check(data: &FrfData, params: &PolymaxParams) -> Result<(), EmaError> {
    if params.max_order == 0 {
        return Err(EmaError::InvalidParam {
            name: "max_order".into(),
            message: "must be at least 1".into(),
        });
    }
    if data.n_lines() < params.max_order + 2 {
        return Err(EmaError::InvalidData(format!(
            "{} frequency lines cannot support model order {}; lower `max_order` or widen `band`",
            data.n_lines(),
            params.max_order
        )));
    }
    Ok(())
}

/// Poles of every model order 1..=max_order (Peeters et al. 2004), from the
/// normal equations built once for the maximum order.
pub fn polymax(data: &FrfData, params: &PolymaxParams) -> Result<Vec<PoleOrder>, EmaError> {
    check(data, params)?;
    let (n, nr) = (params.max_order, data.n_ref());
    let dt = sampling_time(data);
    let zk = powers(data, n, dt);
    let (n1, m) = (n + 1, (n + 1) * nr);
    // Per output: T_o and G_o = L_o⁻¹ S_o (parallel, collected in output order).
    let per_output: Vec<(Vec<f64>, Vec<f64>)> = (0..data.n_out())
        .into_par_iter()
        .map(|o| {
            let b = blocks(data, o, n, &zk);
            let L = factor(&b.R, n1, n)?;
            let mut G = b.S;
            forward_substitute(&L, n1, &mut G, m, n1);
            Ok((b.T, G))
        })
        .collect::<Result<_, EmaError>>()?;
    let (kernels, G): (Vec<Vec<f64>>, Vec<Vec<f64>>) = per_output.into_iter().unzip();
    let mut P = vec![0.0; m * m];
    for T in kernels {
        for (p, t) in P.iter_mut().zip(T) {
            *p += t;
        }
    }
    // M(k) = 2 (Σ T − Σ_{j≤k} Σ_o g_jᵀ g_j): one rank-n_out update per order,
    // over the whole matrix since later orders read its larger leading blocks.
    // Each order's reduced matrix is solved as soon as a thread is free for
    // it: all of them at once took Σ_k ((k+1) n_ref)² numbers (870 MB for 72
    // references at order 40).
    let batch = rayon::current_num_threads().max(1);
    let mut pending: Vec<(usize, Vec<f64>)> = Vec::with_capacity(batch);
    let mut solved = Vec::with_capacity(n);
    for k in 0..n1 {
        let mk = (k + 1) * nr;
        for G in &G {
            let g = &G[k * m..(k + 1) * m];
            for a in 0..m {
                let ga = g[a];
                if ga != 0.0 {
                    for (p, gb) in P[a * m..(a + 1) * m].iter_mut().zip(g) {
                        *p -= ga * gb;
                    }
                }
            }
        }
        if k >= 1 {
            let mut M = vec![0.0; mk * mk];
            for a in 0..mk {
                for b in 0..mk {
                    M[a * mk + b] = 2.0 * P[a * m + b];
                }
            }
            pending.push((k, M));
        }
        if pending.len() == batch || (k == n && !pending.is_empty()) {
            let orders: Vec<Result<PoleOrder, EmaError>> = std::mem::take(&mut pending)
                .into_par_iter()
                .map(|(k, M)| solve_order(&M, k, nr, dt))
                .collect();
            solved.extend(orders);
        }
    }
    solved.into_iter().collect()
}

/// The reference implementation: the kernel sums and reduced normal equations
/// rebuilt from the data for every order separately. Same poles as
/// [`polymax`] up to rounding; kept to check and benchmark the reuse.
pub fn polymax_rebuild_per_order(
    data: &FrfData,
    params: &PolymaxParams,
) -> Result<Vec<PoleOrder>, EmaError> {
    check(data, params)?;
    let nr = data.n_ref();
    let dt = sampling_time(data);
    (1..=params.max_order)
        .into_par_iter()
        .map(|n| {
            let zk = powers(data, n, dt);
            let (n1, m) = (n + 1, (n + 1) * nr);
            let mut M = vec![0.0; m * m];
            for o in 0..data.n_out() {
                let b = blocks(data, o, n, &zk);
                let L = factor(&b.R, n1, n)?;
                let mut G = b.S;
                forward_substitute(&L, n1, &mut G, m, n1);
                for a in 0..m {
                    for c in 0..m {
                        let gg: f64 = (0..n1).map(|k| G[k * m + a] * G[k * m + c]).sum();
                        M[a * m + c] += 2.0 * (b.T[a * m + c] - gg);
                    }
                }
            }
            solve_order(&M, n, nr, dt)
        })
        .collect()
}

/// Denominator coefficients from the reduced matrix of order n, then the
/// companion eigenvalues and eigenvectors.
fn solve_order(M: &[f64], n: usize, nr: usize, dt: f64) -> Result<PoleOrder, EmaError> {
    let (ma, mk) = (n * nr, (n + 1) * nr);
    let mut Maa = vec![0.0; ma * ma];
    let mut alpha = vec![0.0; ma * nr];
    for a in 0..ma {
        Maa[a * ma..(a + 1) * ma].copy_from_slice(&M[a * mk..a * mk + ma]);
        for i in 0..nr {
            alpha[a * nr + i] = -M[a * mk + ma + i];
        }
    }
    let L = factor(&Maa, ma, n)?;
    forward_substitute(&L, ma, &mut alpha, nr, ma);
    backward_substitute_t(&L, ma, &mut alpha, nr);
    // Block companion of D(z)ᵀ: C l = z l with l = [w; z w; …], Σ z^r α_rᵀ w = 0.
    let C = faer::Mat::<f64>::from_fn(ma, ma, |row, col| {
        let (br, i) = (row / nr, row % nr);
        if br + 1 < n {
            f64::from(col == row + nr)
        } else {
            let (r, j) = (col / nr, col % nr);
            -alpha[(r * nr + j) * nr + i]
        }
    });
    let eig = eigen_sequential(&C, nr).ok_or(EmaError::NoConvergence { order: n })?;
    let mut poles = Vec::new();
    for (z, l) in eig {
        if z.norm() == 0.0 {
            continue;
        }
        let s = z.ln() / dt;
        if s.im <= 0.0 || !s.re.is_finite() {
            continue;
        }
        let w = s.norm();
        poles.push(Pole {
            s,
            frequency_hz: w / (2.0 * PI),
            damping_ratio: -s.re / w,
            participation: normalize(l),
        });
    }
    poles.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    Ok(PoleOrder { order: n, poles })
}

/// Eigenvalues of a real matrix with the first `head` entries of their right
/// eigenvectors, computed with `Par::Seq` whatever faer's global parallelism
/// (the `rayon` feature makes it all threads by default), so the poles do not
/// depend on the thread count. faer stores a complex pair's eigenvector as
/// real and imaginary parts in two consecutive columns.
fn eigen_sequential(C: &faer::Mat<f64>, head: usize) -> Option<Vec<(Complex64, Vec<Complex64>)>> {
    use faer::linalg::evd::{evd_real, evd_scratch, ComputeEigenvectors};
    let n = C.nrows();
    let mut U = faer::Mat::<f64>::zeros(n, n);
    let mut re = faer::diag::Diag::<f64>::zeros(n);
    let mut im = faer::diag::Diag::<f64>::zeros(n);
    let req = evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::Yes,
        faer::Par::Seq,
        Default::default(),
    );
    let mut mem = faer::dyn_stack::MemBuffer::new(req);
    evd_real(
        C.as_ref(),
        re.as_mut(),
        im.as_mut(),
        None,
        Some(U.as_mut()),
        faer::Par::Seq,
        faer::dyn_stack::MemStack::new(&mut mem),
        Default::default(),
    )
    .ok()?;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    while j < n {
        if im[j] == 0.0 || j + 1 == n {
            let v = (0..head).map(|i| Complex64::new(U[(i, j)], 0.0)).collect();
            out.push((Complex64::new(re[j], im[j]), v));
            j += 1;
        } else {
            let v: Vec<Complex64> = (0..head)
                .map(|i| Complex64::new(U[(i, j)], U[(i, j + 1)]))
                .collect();
            let conj = v.iter().map(Complex64::conj).collect();
            out.push((Complex64::new(re[j], im[j]), v));
            out.push((Complex64::new(re[j], -im[j]), conj));
            j += 2;
        }
    }
    Some(out)
}

/// Unit norm, largest entry real positive: a deterministic phase.
pub(crate) fn normalize(v: Vec<Complex64>) -> Vec<Complex64> {
    let norm = v.iter().map(Complex64::norm_sqr).sum::<f64>().sqrt();
    let Some(big) = v
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
    else {
        return v;
    };
    if norm == 0.0 {
        return v;
    }
    let phase = big.conj() / big.norm();
    v.into_iter().map(|x| x * phase / norm).collect()
}
