//! Least-squares frequency-domain (LSFD) estimation of residues and mode
//! shapes for given poles (Peeters et al. 2004, section 2.4; Heylen, Lammens &
//! Sas, "Modal Analysis Theory and Testing", 1997):
//!
//! H_oi(ω) = Σ_r [ R_oi,r/(jω − λ_r) + R*_oi,r/(jω − λ*_r) ] − LR_oi/ω² + UR_oi,
//!
//! linear in the complex residues R and the real lower and upper residuals,
//! solved for all channels at once with one Householder QR factorization of
//! the real design matrix [Re; Im] (sequential, so bit-identical on any
//! thread count). The shape of mode r is the dominant left
//! singular vector of its residue matrix R_r = ψ_r L_rᵀ (outputs × references).
//! A repeated root of multiplicity m has one pole and a residue matrix of
//! rank m, R = Σ_k ψ_k L_kᵀ: its m shapes are the m leading left singular
//! vectors, an orthonormal basis of the modal subspace (the individual
//! shapes of an exactly repeated root are not determined by FRFs, only
//! their span). The fitted model reconstructs the FRFs, scored by FRAC
//! (eq. 2.66).

#![allow(non_snake_case)]

use super::hermitian::left_singular;
use super::{EmaError, FrfData};
use crate::dense::least_squares;
use crate::metrics::frac;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Residues, residuals, shapes and reconstructed FRFs of an LSFD fit.
#[derive(Clone, Debug, PartialEq)]
pub struct LsfdFit {
    /// Per mode, residues over channels `o · n_ref + i`.
    pub residues: Vec<Vec<Complex64>>,
    /// Lower residual per channel (the −LR/ω² term).
    pub lower: Vec<f64>,
    /// Upper residual per channel.
    pub upper: Vec<f64>,
    /// Per mode, the shape over the outputs: unit norm, largest entry real
    /// positive. A root of multiplicity m contributes m consecutive shapes.
    pub shapes: Vec<Vec<Complex64>>,
    /// Per shape, the index of its pole in the fitted pole list.
    pub shape_pole: Vec<usize>,
    /// Reconstructed FRFs in the layout of [`FrfData::h`].
    pub reconstructed: Vec<Complex64>,
}

impl LsfdFit {
    /// Mean FRAC (eq. 2.66) over all channels between `data` and the fit.
    pub fn mean_frac(&self, data: &FrfData) -> f64 {
        let nf = data.n_lines();
        let n_ch = data.n_out() * data.n_ref();
        (0..n_ch)
            .map(|c| {
                frac(
                    &data.h[c * nf..(c + 1) * nf],
                    &self.reconstructed[c * nf..(c + 1) * nf],
                )
            })
            .sum::<f64>()
            / n_ch as f64
    }
}

/// Fit residues for the poles `lambdas` (rad/s, positive imaginary parts),
/// one mode per pole.
pub fn lsfd(data: &FrfData, lambdas: &[Complex64]) -> Result<LsfdFit, EmaError> {
    lsfd_roots(data, lambdas, &vec![1; lambdas.len()])
}

/// As [`lsfd`], with `multiplicity[r]` modes at pole r.
pub fn lsfd_roots(
    data: &FrfData,
    lambdas: &[Complex64],
    multiplicity: &[usize],
) -> Result<LsfdFit, EmaError> {
    assert_eq!(
        lambdas.len(),
        multiplicity.len(),
        "one multiplicity per pole"
    );
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    let n_col = 2 * lambdas.len() + 2;
    if 2 * nf < n_col {
        return Err(EmaError::InvalidData(format!(
            "{nf} lines cannot fit {} modes with residuals",
            lambdas.len()
        )));
    }
    if data.frequencies_hz.iter().any(|&f| f <= 0.0) {
        return Err(EmaError::InvalidData(
            "LSFD with a lower residual needs lines above 0 Hz; start the band above 0".into(),
        ));
    }
    let rows = 2 * nf;
    let (mut A, scale) = design_matrix(data, lambdas);
    let mut B = data_matrix(data);
    let X = least_squares(&mut A, rows, n_col, &mut B, n_ch).ok_or_else(|| {
        EmaError::InvalidData("LSFD design matrix is rank deficient (coincident poles)".into())
    })?;
    let x = Coefficients { X, scale, n_col };
    let residues: Vec<Vec<Complex64>> = (0..lambdas.len())
        .map(|r| {
            (0..n_ch)
                .map(|ch| Complex64::new(x.at(2 * r, ch), x.at(2 * r + 1, ch)))
                .collect()
        })
        .collect();
    let lower: Vec<f64> = (0..n_ch).map(|ch| x.at(2 * lambdas.len(), ch)).collect();
    let upper: Vec<f64> = (0..n_ch)
        .map(|ch| x.at(2 * lambdas.len() + 1, ch))
        .collect();
    let reconstructed = reconstruct(data, lambdas, &x);
    let (shapes, shape_pole) = shapes(data, &residues, multiplicity);
    Ok(LsfdFit {
        residues,
        lower,
        upper,
        shapes,
        shape_pole,
        reconstructed,
    })
}

/// Column `col` of the LSFD model at line `f`: for pole r the real and
/// imaginary parts of its residue (columns 2r, 2r + 1) multiply
/// 1/(jω − λ) ± 1/(jω − λ*), then come the lower residual (−1/ω²) and the
/// upper residual (1).
fn basis(data: &FrfData, lambdas: &[Complex64], f: usize, col: usize) -> Complex64 {
    let j = Complex64::new(0.0, 1.0);
    let w = 2.0 * PI * data.frequencies_hz[f];
    let jw = Complex64::new(0.0, w);
    // On whitened data (h = u·H) the column is whitened too ([`super::whitening`]).
    data.line_weight[f]
        * match col {
            c if c < 2 * lambdas.len() => {
                let l = lambdas[c / 2];
                let (p, q) = (1.0 / (jw - l), 1.0 / (jw - l.conj()));
                if c % 2 == 0 {
                    p + q
                } else {
                    j * p - j * q
                }
            }
            c if c == 2 * lambdas.len() => Complex64::new(-1.0 / (w * w), 0.0),
            _ => Complex64::new(1.0, 0.0),
        }
}

/// The real design matrix [Re; Im] of the [`basis`] (column-major, 2 n_f
/// rows), its columns scaled to unit norm, and the scale of each column.
fn design_matrix(data: &FrfData, lambdas: &[Complex64]) -> (Vec<f64>, Vec<f64>) {
    let nf = data.n_lines();
    let n_col = 2 * lambdas.len() + 2;
    let rows = 2 * nf;
    // Column-major design matrix [Re; Im].
    let mut A = vec![0.0; rows * n_col];
    for col in 0..n_col {
        for f in 0..nf {
            let b = basis(data, lambdas, f, col);
            A[col * rows + f] = b.re;
            A[col * rows + nf + f] = b.im;
        }
    }
    // Column scaling to unit norm: the residual columns differ by orders of magnitude.
    let scale: Vec<f64> = (0..n_col)
        .map(|c| {
            let s = A[c * rows..(c + 1) * rows]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt();
            if s > 0.0 {
                1.0 / s
            } else {
                1.0
            }
        })
        .collect();
    for (c, s) in scale.iter().enumerate() {
        A[c * rows..(c + 1) * rows].iter_mut().for_each(|v| *v *= s);
    }
    (A, scale)
}

/// The right-hand sides [Re; Im] of every channel (column-major, 2 n_f rows).
fn data_matrix(data: &FrfData) -> Vec<f64> {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    let rows = 2 * nf;
    let mut B = vec![0.0; rows * n_ch];
    for ch in 0..n_ch {
        for f in 0..nf {
            let v = data.h[ch * nf + f];
            B[ch * rows + f] = v.re;
            B[ch * rows + nf + f] = v.im;
        }
    }
    B
}

/// The least-squares solution of the scaled design matrix, per channel.
struct Coefficients {
    /// Solution for the scaled columns (`n_col` per channel).
    X: Vec<f64>,
    /// Scale of each column ([`design_matrix`]).
    scale: Vec<f64>,
    n_col: usize,
}

impl Coefficients {
    /// The coefficient of column `col` for channel `ch`, unscaled.
    fn at(&self, col: usize, ch: usize) -> f64 {
        self.X[ch * self.n_col + col] * self.scale[col]
    }
}

/// The fitted FRFs Σ_c basis_c · x_c, in the layout of [`FrfData::h`].
fn reconstruct(data: &FrfData, lambdas: &[Complex64], x: &Coefficients) -> Vec<Complex64> {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    let mut reconstructed = vec![Complex64::new(0.0, 0.0); n_ch * nf];
    for f in 0..nf {
        let row: Vec<Complex64> = (0..x.n_col).map(|c| basis(data, lambdas, f, c)).collect();
        for ch in 0..n_ch {
            reconstructed[ch * nf + f] = row.iter().enumerate().map(|(c, b)| b * x.at(c, ch)).sum();
        }
    }
    reconstructed
}

/// The shapes of each pole, the `multiplicity` leading left singular
/// vectors of its residue matrix (at least one), and the pole of each shape.
fn shapes(
    data: &FrfData,
    residues: &[Vec<Complex64>],
    multiplicity: &[usize],
) -> (Vec<Vec<Complex64>>, Vec<usize>) {
    let mut shapes = Vec::new();
    let mut shape_pole = Vec::new();
    for (r, (res, &m)) in residues.iter().zip(multiplicity).enumerate() {
        let (_, u) = left_singular(res, data.n_out(), data.n_ref());
        for v in u.into_iter().take(m.max(1)) {
            shapes.push(super::polymax::normalize(v));
            shape_pole.push(r);
        }
    }
    (shapes, shape_pole)
}
