//! How a prepared model holds its body matrices M, K₀, D₀ and solves an
//! evaluation: dense (reduced models, Craig–Bampton blocks: dense Cholesky
//! of K_σ) or sparse (unreduced FE bodies: one symbolic analysis of the
//! pattern of K₀ + σM + every joint term of every configuration, then a
//! numeric factorization per evaluation into reused storage). Both run the
//! same shift-invert block Lanczos ([`super::lanczos`]); a dense model
//! whose wanted modes are a large share of its DOFs uses the full
//! symmetric eigensolver instead.
#![allow(non_snake_case)]

use super::assembly::{Configuration, JointTerms};
use super::eigen::{cholesky, shift_invert_factored};
use super::error::DynamicsError;
use super::lanczos::{LanczosError, LanczosOptions};
use super::model_file::SolverMethod;
use super::shift_invert::{lowest_modes, DenseShiftInvert, SparseShiftInvert, Workspace};
use super::sparse::{Csc, SparseCholesky};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// Dense storage: M, K₀, D₀ and the Cholesky factor C of M for the full
/// eigensolver (`None` when M is only semi-definite: massless DOFs).
#[derive(Debug, Clone)]
pub struct DenseStorage {
    pub M: Mat<f64>,
    pub K0: Mat<f64>,
    pub D0: Option<Mat<f64>>,
    pub M_chol: Option<Mat<f64>>,
}

/// Sparse storage: M, K₀, D₀, K₀ and M on the union pattern of every
/// evaluation's K_σ = K₀ + σM + joints (σ is chosen per model, so it is
/// applied at factorization), its symbolic Cholesky analysis, and for every
/// configuration the value slots of its rank-one spring terms.
#[derive(Debug)]
pub struct SparseStorage {
    pub M: Csc,
    pub K0: Csc,
    pub D0: Option<Csc>,
    /// K₀ on the union pattern.
    K_pattern: Csc,
    /// M's values on the same pattern.
    mass_on_pattern: Vec<f64>,
    chol: SparseCholesky,
    /// slots[config][column] = positions in K_pattern.values of g gᵀ.
    slots: Vec<Vec<Vec<usize>>>,
}

/// The body matrices of a prepared model (one per model, behind an `Arc`,
/// so the variants' sizes do not matter).
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub enum Storage {
    Dense(DenseStorage),
    Sparse(Box<SparseStorage>),
}

/// Dense when the model is small or its K_σ is dense anyway: below 1,500
/// DOF or above 5 % fill (measured crossover, README "Performance").
pub fn choose(method: SolverMethod, n: usize, nnz: usize) -> SolverMethod {
    match method {
        SolverMethod::Auto if n < 1500 || nnz as f64 > 0.05 * (n as f64).powi(2) => {
            SolverMethod::Dense
        }
        SolverMethod::Auto => SolverMethod::Sparse,
        m => m,
    }
}

/// M must be positive semi-definite: a DOF of negative mass has no
/// physical meaning and makes the shift-inverted operator indefinite. A
/// zero diagonal (a massless DOF: rotations of a lumped-mass model,
/// constraint nodes) is allowed; shift-invert needs K + σM definite, not M.
fn check_mass_diagonal(M: &Csc, labels: &[String]) -> Result<(), DynamicsError> {
    for j in 0..M.n {
        let d = M.get(j, j);
        if d < 0.0 || !d.is_finite() {
            return Err(DynamicsError::MassNotPositiveDefinite {
                pivot: j,
                dof: labels.get(j).cloned().unwrap_or_default(),
            });
        }
    }
    Ok(())
}

/// Number of DOFs whose mass row is zero (massless DOFs).
pub fn massless_dofs(M: &Csc) -> usize {
    (0..M.n)
        .filter(|&j| (M.col_ptr[j]..M.col_ptr[j + 1]).all(|p| M.values[p] == 0.0))
        .count()
}

fn stiffness_error(pivot: usize, labels: &[String]) -> DynamicsError {
    DynamicsError::StiffnessIndefinite {
        pivot,
        dof: labels.get(pivot).cloned().unwrap_or_default(),
    }
}

impl Storage {
    /// Build the storage for `method` (not `Auto`) from assembled matrices.
    pub fn new(
        method: SolverMethod,
        M: Csc,
        K0: Csc,
        D0: Option<Csc>,
        configurations: &[Configuration],
        labels: &[String],
    ) -> Result<Storage, DynamicsError> {
        check_mass_diagonal(&M, labels)?;
        if method != SolverMethod::Sparse {
            let (M, K0) = (M.to_dense(), K0.to_dense());
            let M_chol = cholesky(&M).ok();
            return Ok(Storage::Dense(DenseStorage {
                M_chol,
                D0: D0.map(|d| d.to_dense()),
                M,
                K0,
            }));
        }
        let n = M.n;
        let mut t = Vec::with_capacity(K0.nnz() + M.nnz());
        K0.triplets(0, 1.0, &mut t);
        M.triplets(0, 0.0, &mut t);
        for c in configurations {
            for g in &c.stiffness.columns {
                for &(i, _) in g {
                    for &(j, _) in g {
                        t.push((i, j, 0.0));
                    }
                }
            }
        }
        let K_pattern = Csc::from_triplets(n, t);
        let slots = configurations
            .iter()
            .map(|c| {
                c.stiffness
                    .columns
                    .iter()
                    .map(|g| {
                        g.iter()
                            .flat_map(|&(i, _)| g.iter().map(move |&(j, _)| (i, j)))
                            .map(|(i, j)| K_pattern.position(i, j).unwrap_or(usize::MAX))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let chol = SparseCholesky::analyse(&K_pattern)
            .map_err(|m| DynamicsError::Parameters { message: m })?;
        let mass_on_pattern = M.on_pattern(&K_pattern).values;
        let K_pattern = K0.on_pattern(&K_pattern);
        Ok(Storage::Sparse(Box::new(SparseStorage {
            M,
            K0,
            D0,
            K_pattern,
            mass_on_pattern,
            chol,
            slots,
        })))
    }

    pub fn n(&self) -> usize {
        match self {
            Storage::Dense(d) => d.M.nrows(),
            Storage::Sparse(s) => s.M.n,
        }
    }

    /// DOFs with mass: the most modes with a finite frequency.
    pub fn finite_modes(&self) -> usize {
        match self {
            Storage::Dense(d) => (0..d.M.nrows())
                .filter(|&j| (0..d.M.nrows()).any(|i| d.M[(i, j)] != 0.0))
                .count(),
            Storage::Sparse(s) => s.M.n - massless_dofs(&s.M),
        }
    }

    pub fn method(&self) -> SolverMethod {
        match self {
            Storage::Dense(_) => SolverMethod::Dense,
            Storage::Sparse(_) => SolverMethod::Sparse,
        }
    }

    /// Non-zeros of the stored K_σ and of its factor (sparse), or n² (dense).
    pub fn nnz(&self) -> (usize, usize) {
        match self {
            Storage::Dense(d) => (d.M.nrows().pow(2), d.M.nrows().pow(2)),
            Storage::Sparse(s) => (s.K_pattern.nnz(), s.chol.factor_nnz()),
        }
    }

    /// Y = M X.
    pub fn mass_mul(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>) {
        match self {
            Storage::Dense(d) => matmul(Y, Accum::Replace, d.M.as_ref(), X, 1.0, Par::Seq),
            Storage::Sparse(s) => s.M.mul(X, Y),
        }
    }

    /// Y = K₀ X.
    pub fn stiffness_mul(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>) {
        match self {
            Storage::Dense(d) => matmul(Y, Accum::Replace, d.K0.as_ref(), X, 1.0, Par::Seq),
            Storage::Sparse(s) => s.K0.mul(X, Y),
        }
    }

    /// X ← K_σ⁻¹ X with the factor in `ws` ([`Storage::factor`]).
    pub fn solve(&self, X: MatMut<'_, f64>, ws: &mut Workspace) {
        match self {
            Storage::Dense(_) => {
                let mut X = X;
                solve_lower_triangular_in_place(ws.dense.as_ref(), X.rb_mut(), Par::Seq);
                solve_upper_triangular_in_place(ws.dense.transpose(), X, Par::Seq);
            }
            Storage::Sparse(s) => s.chol.solve(X, &mut ws.factor),
        }
    }

    /// Frobenius norms of M and K₀.
    pub fn norms(&self) -> (f64, f64) {
        match self {
            Storage::Dense(d) => (d.M.norm_l2(), d.K0.norm_l2()),
            Storage::Sparse(s) => (s.M.norm_frobenius(), s.K0.norm_frobenius()),
        }
    }

    /// Whether the bodies have material damping D₀.
    pub fn has_material_damping(&self) -> bool {
        match self {
            Storage::Dense(d) => d.D0.is_some(),
            Storage::Sparse(s) => s.D0.is_some(),
        }
    }

    /// diag(Φᵀ D₀ Φ), or zeros without material damping.
    pub fn material_diagonal(&self, Phi: &Mat<f64>) -> Vec<f64> {
        let (n, m) = (Phi.nrows(), Phi.ncols());
        let mut W = Mat::<f64>::zeros(n, m);
        match self {
            Storage::Dense(DenseStorage { D0: Some(D0), .. }) => matmul(
                W.as_mut(),
                Accum::Replace,
                D0.as_ref(),
                Phi.as_ref(),
                1.0,
                Par::Seq,
            ),
            Storage::Sparse(s) if s.D0.is_some() => {
                if let Some(D0) = &s.D0 {
                    D0.mul(Phi.as_ref(), W.as_mut())
                }
            }
            _ => return vec![0.0; m],
        }
        (0..m)
            .map(|r| (0..n).map(|i| Phi[(i, r)] * W[(i, r)]).sum())
            .collect()
    }

    /// Dense M, K₀, D₀ (for direct solutions and checks).
    pub fn dense(&self) -> (Mat<f64>, Mat<f64>, Option<Mat<f64>>) {
        match self {
            Storage::Dense(d) => (d.M.clone(), d.K0.clone(), d.D0.clone()),
            Storage::Sparse(s) => (
                s.M.to_dense(),
                s.K0.to_dense(),
                s.D0.as_ref().map(Csc::to_dense),
            ),
        }
    }

    /// Factor K_σ = K₀ + σM + Σ k g gᵀ of configuration `config` into `ws`.
    #[allow(clippy::too_many_arguments)]
    pub fn factor(
        &self,
        config: usize,
        terms: &JointTerms,
        values: &[f64],
        shift: f64,
        ws: &mut Workspace,
        labels: &[String],
    ) -> Result<(), DynamicsError> {
        match self {
            Storage::Dense(d) => {
                let n = d.M.nrows();
                if ws.dense.nrows() != n || ws.dense.ncols() != n {
                    ws.dense = Mat::zeros(n, n);
                }
                for j in 0..n {
                    for i in 0..n {
                        ws.dense[(i, j)] = d.K0[(i, j)] + shift * d.M[(i, j)];
                    }
                }
                terms.add_to(&mut ws.dense, values);
                super::eigen::cholesky_in_place(&mut ws.dense)
                    .map_err(|p| stiffness_error(p, labels))
            }
            Storage::Sparse(s) => {
                ws.values.clear();
                ws.values.extend(
                    s.K_pattern
                        .values
                        .iter()
                        .zip(&s.mass_on_pattern)
                        .map(|(k, m)| k + shift * m),
                );
                for ((g, &p), slot) in terms
                    .columns
                    .iter()
                    .zip(&terms.params)
                    .zip(&s.slots[config])
                {
                    let v = values[p];
                    let mut q = 0;
                    for &(_, gi) in g {
                        for &(_, gj) in g {
                            if let Some(x) = ws.values.get_mut(slot[q]) {
                                *x += v * gi * gj;
                            }
                            q += 1;
                        }
                    }
                }
                s.chol
                    .factor(&s.K_pattern, &ws.values, &mut ws.factor)
                    .map_err(|p| stiffness_error(p, labels))
            }
        }
    }

    /// Lowest `nev` modes with the factor in `ws` ([`Storage::factor`]).
    pub fn lowest(
        &self,
        nev: usize,
        shift: f64,
        options: &LanczosOptions,
        ws: &mut Workspace,
    ) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
        let n = self.n();
        let nev = nev.min(n);
        let lanczos_error = |e: LanczosError| {
            match e {
            LanczosError::NotConverged { restarts, residual } => DynamicsError::Lanczos {
                message: format!(
                    "{nev} modes not converged after {restarts} restarts (relative residual {residual:.1e}); raise `solver.block` or lower the mode count"
                ),
            },
            LanczosError::TooSmall => DynamicsError::NoConvergence,
            LanczosError::NonPositive { wanted, positive } => DynamicsError::Lanczos {
                message: format!(
                    "{wanted} modes wanted but only {positive} have a finite frequency: the mass matrix has massless DOFs (rank below the mode count) or is indefinite; ask for fewer modes or check the mass matrix"
                ),
            },
        }
        };
        match self {
            Storage::Dense(d) => {
                if 3 * nev <= n {
                    let mut op = DenseShiftInvert {
                        L: &ws.dense,
                        M: &d.M,
                    };
                    match lowest_modes(&mut op, shift, nev, options, &mut ws.krylov) {
                        Err(LanczosError::TooSmall) => {}
                        r => return r.map_err(lanczos_error),
                    }
                }
                shift_invert_factored(&ws.dense, d.M_chol.as_ref(), &d.M, shift, nev)
            }
            Storage::Sparse(s) => {
                let Workspace { krylov, factor, .. } = ws;
                let mut op = SparseShiftInvert {
                    chol: &s.chol,
                    factor,
                    M: &s.M,
                };
                match lowest_modes(&mut op, shift, nev, options, krylov) {
                    Err(LanczosError::TooSmall) => Err(DynamicsError::Lanczos {
                        message: format!(
                            "a model of {n} DOF is too small for {nev} modes by sparse Lanczos; use `solver: {{method: dense}}`"
                        ),
                    }),
                    r => r.map_err(lanczos_error),
                }
            }
        }
    }
}
