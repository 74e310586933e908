//! Sparse symmetric matrices for unreduced FE models: compressed sparse
//! columns with both triangles stored (products need the whole matrix, the
//! Cholesky factorization reads the lower one), and the sparse Cholesky
//! factorization K + σM = P L Lᵀ Pᵀ of faer with its fill-reducing (AMD)
//! ordering and symbolic analysis computed once per sparsity pattern.
//! Joint parameters change values, never the pattern, so every evaluation
//! only refactors numerically into reused storage. Numeric factorization
//! and solves run with `Par::Seq`: bit-identical for any thread count.
#![allow(non_snake_case)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, simplicial, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, MatRef, Par, Side};

/// A square symmetric sparse matrix in compressed sparse columns (both
/// triangles stored), rows sorted within each column, duplicates summed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Csc {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

impl Csc {
    /// Build from (row, column, value) triplets; duplicates are summed in a
    /// fixed order (sorted by position, then by input order).
    ///
    /// A stable counting sort by column, then a stable sort of each column
    /// by row: the same order as one stable sort by (column, row), so the
    /// same sums bit for bit, in O(nnz) plus short sorts (the one sort of
    /// up to 1.4 M triplets was ~5 % of a 30-mode run at 9,963 DOF,
    /// `benchmarks/fe_many_modes.rs`).
    pub fn from_triplets(n: usize, t: Vec<(usize, usize, f64)>) -> Csc {
        let mut start = vec![0usize; n + 1];
        for &(_, j, _) in &t {
            start[j + 1] += 1;
        }
        for j in 0..n {
            start[j + 1] += start[j];
        }
        let mut next = start.clone();
        let mut sorted = vec![(0usize, 0.0f64); t.len()];
        for (i, j, v) in t {
            sorted[next[j]] = (i, v);
            next[j] += 1;
        }
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(sorted.len());
        let mut values: Vec<f64> = Vec::with_capacity(sorted.len());
        for j in 0..n {
            let column = &mut sorted[start[j]..start[j + 1]];
            column.sort_by_key(|e| e.0);
            let mut last = None;
            for &(i, v) in column.iter() {
                if last == Some(i) {
                    if let Some(x) = values.last_mut() {
                        *x += v;
                    }
                    continue;
                }
                last = Some(i);
                row_idx.push(i);
                values.push(v);
            }
            col_ptr[j + 1] = row_idx.len();
        }
        Csc {
            n,
            col_ptr,
            row_idx,
            values,
        }
    }

    /// All non-zeros of a dense block placed at (offset, offset).
    pub fn dense_triplets(A: &Mat<f64>, offset: usize, out: &mut Vec<(usize, usize, f64)>) {
        for j in 0..A.ncols() {
            for i in 0..A.nrows() {
                let v = A[(i, j)];
                if v != 0.0 {
                    out.push((offset + i, offset + j, v));
                }
            }
        }
    }

    /// The triplets of this matrix shifted by `offset`, scaled by `scale`.
    pub fn triplets(&self, offset: usize, scale: f64, out: &mut Vec<(usize, usize, f64)>) {
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                out.push((offset + self.row_idx[p], offset + j, scale * self.values[p]));
            }
        }
    }

    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Index into `values` of entry (i, j), if it is in the pattern.
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        let (a, b) = (self.col_ptr[j], self.col_ptr[j + 1]);
        self.row_idx[a..b].binary_search(&i).ok().map(|p| a + p)
    }

    /// Entry (i, j) (0 outside the pattern).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.position(i, j).map_or(0.0, |p| self.values[p])
    }

    /// The same pattern as `pattern` (which must contain this one) with
    /// this matrix's values, zero elsewhere.
    pub fn on_pattern(&self, pattern: &Csc) -> Csc {
        let mut out = Csc {
            values: vec![0.0; pattern.nnz()],
            ..pattern.clone()
        };
        // Rows are sorted in both: one merge per column.
        for j in 0..self.n {
            let mut q = pattern.col_ptr[j];
            let end = pattern.col_ptr[j + 1];
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                while q < end && pattern.row_idx[q] < i {
                    q += 1;
                }
                if q < end && pattern.row_idx[q] == i {
                    out.values[q] += self.values[p];
                }
            }
        }
        out
    }

    /// Y = A X (Y overwritten) for symmetric A, up to eight columns per
    /// sweep over the matrix. The product is bound by reading A (16 bytes
    /// per non-zero for 2 flops per column), so one sweep for a Lanczos
    /// block of 4, or four for the 30 modes of a residual check instead of
    /// 30, cuts its cost nearly by the column count (README "One
    /// evaluation against LAPACK/ARPACK"). Each column's sum runs in the
    /// same order as a one-column product, so the result does not depend
    /// on how columns are grouped.
    pub fn mul(&self, X: MatRef<'_, f64>, mut Y: MatMut<'_, f64>) {
        let mut c0 = 0;
        while c0 < X.ncols() {
            let w = (X.ncols() - c0).min(8);
            let (x, y) = (X.subcols(c0, w), Y.rb_mut().subcols_mut(c0, w));
            match w {
                8 => self.mul_block::<8>(x, y),
                7 => self.mul_block::<7>(x, y),
                6 => self.mul_block::<6>(x, y),
                5 => self.mul_block::<5>(x, y),
                4 => self.mul_block::<4>(x, y),
                3 => self.mul_block::<3>(x, y),
                2 => self.mul_block::<2>(x, y),
                _ => self.mul_block::<1>(x, y),
            }
            c0 += w;
        }
    }

    /// Y = A X for exactly `W` columns: X interleaved row by row (the W
    /// values a non-zero multiplies share one cache line), then
    /// y_j = Σ_p A_pj x_p as a gather over the stored columns (column j of
    /// a symmetric A is its row j), the W sums held in registers.
    fn mul_block<const W: usize>(&self, X: MatRef<'_, f64>, mut Y: MatMut<'_, f64>) {
        let mut x = vec![[0.0f64; W]; self.n];
        for c in 0..W {
            let col = X.col(c);
            for (i, xi) in x.iter_mut().enumerate() {
                xi[c] = col[i];
            }
        }
        for j in 0..self.n {
            let (a, b) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let mut s = [0.0; W];
            for (&i, &v) in self.row_idx[a..b].iter().zip(&self.values[a..b]) {
                let xi = &x[i];
                for c in 0..W {
                    s[c] += v * xi[c];
                }
            }
            for (c, &sc) in s.iter().enumerate() {
                Y[(j, c)] = sc;
            }
        }
    }

    pub fn to_dense(&self) -> Mat<f64> {
        let mut A = Mat::zeros(self.n, self.n);
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                A[(self.row_idx[p], j)] += self.values[p];
            }
        }
        A
    }

    /// Frobenius norm.
    pub fn norm_frobenius(&self) -> f64 {
        self.values.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// First (i, j) where A and Aᵀ differ by more than `rel` relative.
    pub fn asymmetry(&self, rel: f64) -> Option<(usize, usize, f64, f64)> {
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                let (a, b) = (self.values[p], self.get(j, i));
                if (a - b).abs() > rel * (a.abs() + b.abs()) {
                    return Some((i, j, a, b));
                }
            }
        }
        None
    }

    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

/// Non-zeros of the Cholesky factor of `A` in its own ordering: the column
/// counts from the elimination tree (Gilbert, Ng & Peyton 1994, as in
/// faer's simplicial analysis), without building the factor's pattern.
fn natural_fill(A: &Csc) -> usize {
    let n = A.n;
    let mut etree = vec![0isize; n];
    let mut counts = vec![0usize; n];
    let mut mem = MemBuffer::new(simplicial::prefactorize_symbolic_cholesky_scratch::<usize>(
        n,
        A.nnz(),
    ));
    simplicial::prefactorize_symbolic_cholesky(
        &mut etree,
        &mut counts,
        A.symbolic(),
        MemStack::new(&mut mem),
    );
    counts.iter().sum()
}

/// Symbolic Cholesky analysis of one sparsity pattern (fill-reducing
/// ordering, [`SparseCholesky::analyse`];
/// elimination tree, supernodes), shared by every numeric factorization.
#[derive(Debug)]
pub struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
}

/// Numeric factor storage and solve workspace, reused across evaluations.
#[derive(Default)]
pub struct FactorWorkspace {
    pub L: Vec<f64>,
    mem: Option<MemBuffer>,
    mem_bytes: usize,
}

impl std::fmt::Debug for FactorWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FactorWorkspace({} bytes)", self.bytes())
    }
}

impl FactorWorkspace {
    fn stack(&mut self, req: faer::dyn_stack::StackReq) -> &mut MemStack {
        let bytes = req.size_bytes();
        if self.mem.is_none() || self.mem_bytes < bytes {
            self.mem = Some(MemBuffer::new(req));
            self.mem_bytes = bytes;
        }
        match self.mem.as_mut() {
            Some(m) => MemStack::new(m),
            None => unreachable!("allocated above"),
        }
    }

    pub fn bytes(&self) -> usize {
        8 * self.L.len() + self.mem_bytes
    }
}

impl SparseCholesky {
    /// Analyse the pattern of `A` (lower triangle used): the AMD ordering,
    /// or the matrix's own when its factor has fewer non-zeros.
    ///
    /// Why both: FE exports are often numbered along the part (mesh
    /// generators sweep it), which is a banded ordering; for the elongated
    /// solids of issue 32 it fills less than AMD, and the solves of the
    /// Lanczos, bound by reading L, cost in proportion (hex8 column at
    /// 9,963 DOF: see `benchmarks/fe_many_modes.md`). The natural fill is
    /// counted first from the elimination tree (O(nnz) time, O(n)
    /// memory), so a badly numbered model never builds its dense symbolic
    /// factor. Both candidates are deterministic: the choice depends only
    /// on the pattern.
    pub fn analyse(A: &Csc) -> Result<SparseCholesky, String> {
        let symbolic = |ordering| {
            factorize_symbolic_cholesky(
                A.symbolic(),
                Side::Lower,
                ordering,
                CholeskySymbolicParams::default(),
            )
            .map_err(|e| format!("symbolic Cholesky analysis failed: {e:?}"))
        };
        let amd = symbolic(SymmetricOrdering::Amd)?;
        if natural_fill(A) < amd.len_val() {
            let natural = symbolic(SymmetricOrdering::Identity)?;
            if natural.len_val() < amd.len_val() {
                return Ok(SparseCholesky { symbolic: natural });
            }
        }
        Ok(SparseCholesky { symbolic: amd })
    }

    /// Non-zeros of the factor L.
    pub fn factor_nnz(&self) -> usize {
        self.symbolic.len_val()
    }

    /// Numeric factorization of the pattern `A` (as analysed) with `values`
    /// into `ws`.
    /// `Err(row)` names the original row of the first non-positive pivot.
    pub fn factor(&self, A: &Csc, values: &[f64], ws: &mut FactorWorkspace) -> Result<(), usize> {
        ws.L.resize(self.symbolic.len_val(), 0.0);
        let req = self
            .symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(self.symbolic.solve_in_place_scratch::<f64>(8, Par::Seq));
        let mut L = std::mem::take(&mut ws.L);
        let stack = ws.stack(req);
        let A = SparseColMatRef::new(A.symbolic(), values);
        let r = self
            .symbolic
            .factorize_numeric_llt(
                &mut L,
                A,
                Side::Lower,
                Default::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map(|_| ())
            .map_err(|e| match e {
                LltError::NonPositivePivot { index } => match self.symbolic.perm() {
                    Some(p) => p.arrays().0.get(index).copied().unwrap_or(index),
                    None => index,
                },
            });
        ws.L = L;
        r
    }

    /// X ← A⁻¹ X with the factor in `ws`.
    pub fn solve(&self, X: MatMut<'_, f64>, ws: &mut FactorWorkspace) {
        let req = self
            .symbolic
            .solve_in_place_scratch::<f64>(X.ncols(), Par::Seq);
        let L = std::mem::take(&mut ws.L);
        {
            let stack = ws.stack(req);
            LltRef::new(&self.symbolic, &L).solve_in_place_with_conj(Conj::No, X, Par::Seq, stack);
        }
        ws.L = L;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triplets_sum_and_products_match_dense() {
        let t = vec![
            (0, 0, 4.0),
            (1, 0, -1.0),
            (0, 1, -1.0),
            (1, 1, 4.0),
            (2, 1, -1.0),
            (1, 2, -1.0),
            (2, 2, 2.0),
            (2, 2, 2.0),
        ];
        let A = Csc::from_triplets(3, t);
        assert_eq!(A.nnz(), 7);
        assert_eq!(A.get(2, 2), 4.0);
        let D = A.to_dense();
        let X = Mat::from_fn(3, 2, |i, j| (i + 2 * j) as f64 - 1.0);
        let mut Y = Mat::zeros(3, 2);
        A.mul(X.as_ref(), Y.as_mut());
        assert_eq!(Y, &D * &X);
        let chol = SparseCholesky::analyse(&A).unwrap();
        let mut ws = FactorWorkspace::default();
        chol.factor(&A, &A.values, &mut ws).unwrap();
        let mut Z = Y.clone();
        chol.solve(Z.as_mut(), &mut ws);
        assert!((&Z - &X).norm_max() < 1e-14, "{Z:?}");
        let bad = Csc::from_triplets(2, vec![(0, 0, 1.0), (1, 1, -1.0)]);
        let chol = SparseCholesky::analyse(&bad).unwrap();
        assert!(chol.factor(&bad, &bad.values, &mut ws).is_err());
        assert_eq!(A.asymmetry(1e-12), None);
        let skew = Csc::from_triplets(2, vec![(0, 1, 1.0), (1, 0, 2.0)]);
        assert!(skew.asymmetry(1e-12).is_some());
    }

    /// A 7 × 7 grid Laplacian numbered row by row (bandwidth 7): the
    /// natural fill from the elimination tree equals an independent count
    /// by dense symbolic elimination, the chosen ordering never fills more
    /// than AMD, and its factor solves.
    #[test]
    fn the_ordering_with_less_fill_is_chosen_and_solves() {
        let (w, n) = (7, 49);
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 4.5));
            for j in [i + 1, i + w] {
                if j < n && (j != i + 1 || (i + 1) % w != 0) {
                    t.push((i, j, -1.0));
                    t.push((j, i, -1.0));
                }
            }
        }
        let A = Csc::from_triplets(n, t);
        // Dense symbolic elimination in the natural order.
        let mut P: Vec<Vec<bool>> = (0..n)
            .map(|i| (0..n).map(|j| A.get(i, j) != 0.0).collect())
            .collect();
        for k in 0..n {
            let below: Vec<usize> = (k + 1..n).filter(|&i| P[i][k]).collect();
            for &i in &below {
                for &j in &below {
                    P[i][j] = true;
                }
            }
        }
        let dense_count = (0..n)
            .map(|j| (j..n).filter(|&i| P[i][j]).count())
            .sum::<usize>();
        assert_eq!(natural_fill(&A), dense_count);
        let amd = factorize_symbolic_cholesky(
            A.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .unwrap();
        let chol = SparseCholesky::analyse(&A).unwrap();
        assert!(chol.factor_nnz() <= amd.len_val());
        let mut ws = FactorWorkspace::default();
        chol.factor(&A, &A.values, &mut ws).unwrap();
        let X = Mat::from_fn(n, 2, |i, j| (i * (j + 2)) as f64 / 10.0 - 1.0);
        let mut Y = Mat::zeros(n, 2);
        A.mul(X.as_ref(), Y.as_mut());
        chol.solve(Y.as_mut(), &mut ws);
        assert!((&Y - &X).norm_max() < 1e-13);
    }

    /// The counting sort sums duplicates in the order of one stable sort by
    /// (column, row), bit for bit; `on_pattern` by merge equals lookups.
    #[test]
    fn triplets_sum_in_stable_sort_order() {
        let n = 30;
        let t: Vec<(usize, usize, f64)> = (0..2000)
            .map(|k| {
                (
                    (k * 7919) % n,
                    (k * 104_729) % n,
                    1.0 / (k + 1) as f64 - 0.3,
                )
            })
            .collect();
        let A = Csc::from_triplets(n, t.clone());
        let mut r = t.clone();
        r.sort_by_key(|a| (a.1, a.0));
        let mut expected: Vec<((usize, usize), f64)> = Vec::new();
        for (i, j, v) in r {
            match expected.last_mut() {
                Some((pos, x)) if *pos == (i, j) => *x += v,
                _ => expected.push(((i, j), v)),
            }
        }
        assert_eq!(A.nnz(), expected.len());
        for ((i, j), v) in expected {
            assert_eq!(A.get(i, j).to_bits(), v.to_bits());
        }
        let sub = Csc::from_triplets(n, t.iter().step_by(7).copied().collect());
        let on = sub.on_pattern(&A);
        for j in 0..n {
            for p in A.col_ptr[j]..A.col_ptr[j + 1] {
                assert_eq!(on.values[p], sub.get(A.row_idx[p], j));
            }
        }
    }

    /// Products of column groups (8, 3) equal one-column products bit for
    /// bit, also for a strided input.
    #[test]
    fn block_products_do_not_depend_on_the_grouping() {
        let n = 40;
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 4.0 + i as f64 / 7.0));
            for k in [1, 3] {
                if i + k < n {
                    let v = ((i * 31 + k) % 17) as f64 / 9.0 - 1.0;
                    t.push((i + k, i, v));
                    t.push((i, i + k, v));
                }
            }
        }
        let A = Csc::from_triplets(n, t);
        let X = Mat::from_fn(n, 11, |i, j| ((i * 7 + j * 13) % 23) as f64 / 5.0 - 2.0);
        let mut Y = Mat::zeros(n, 11);
        A.mul(X.as_ref(), Y.as_mut());
        let XT = X.transpose().to_owned();
        for j in 0..11 {
            let mut y = Mat::zeros(n, 1);
            A.mul(X.subcols(j, 1), y.as_mut());
            assert_eq!(y.col(0), Y.col(j));
            // A row of the transposed copy: a strided column view.
            A.mul(XT.transpose().subcols(j, 1), y.as_mut());
            assert_eq!(y.col(0), Y.col(j));
        }
        assert!((&Y - A.to_dense() * &X).norm_max() < 1e-12);
    }
}
