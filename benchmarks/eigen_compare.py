"""One model evaluation (lowest 30 modes + modal damping + receptances at
all sensor/excitation pairs on 1000 lines) by modalflow against scipy in the
same script, on the same matrices (issue 16):

* dense: the test bench (216 DOF) and unreduced copies with 2x and 6x the
  beam elements (1,038 and 3,054 DOF) against
  scipy.linalg.eigh(K, M, subset_by_index=[0, 29]) (LAPACK dsygvx);
* sparse: unreduced copies with 20x, 100x, 375x the elements (~1e4, 5e4,
  2e5 DOF) against scipy.sparse.linalg.eigsh(K, 30, M, sigma=-s) (ARPACK
  shift-invert on a SuperLU factor).

Interleaved best-of-n wall time, one thread each (OPENBLAS_NUM_THREADS=1).
modalflow's figure excludes its one-time preparation (symbolic analysis),
which is printed separately; scipy has no such split.

max |df/f| is the largest frequency difference between the two. The scaled
copies refine the beams to elements of a fraction of a millimetre, so the
bending terms 12EI/h^3 grow with the cube of the scale (max |K| 1e18 at
1e4, 1.4e20 at 5e4, 7.3e21 at 2e5 DOF): K + sM is then so ill-conditioned
that SuperLU's partial-pivoting solves are accurate in backward error only
(forward error O(1) on a random right-hand side at 5e4 DOF), ARPACK's
lowest frequencies drift by percents at 5e4 and come out negative at 2e5,
and modalflow's Cholesky-based ones drift from their mesh-converged values
too (README). The timings stand; these models are not accuracy references.

    cargo bench --bench dynamics --no-run
    python3 benchmarks/eigen_compare.py target/release/deps/dynamics-<hash> [rounds]
"""
import json
import os
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy.linalg as sl  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

BIN = sys.argv[1]
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 3
CASES = [("dense 216", 0, "dense"), ("dense 1038", 2, "dense"), ("dense 3054", 6, "dense"),
         ("sparse 1e4", 20, "sparse"), ("sparse 5e4", 100, "sparse"), ("sparse 2e5", 375, "sparse")]
only = os.environ.get("CASES")
if only:
    CASES = [c for c in CASES if c[0] in only.split(",")]


def load(d, tag):
    f = lambda s: np.fromfile(os.path.join(d, f"{tag}.{s}"), dtype="<f8")
    n = json.load(open(os.path.join(d, "meta.json")))["n"]
    return sp.csc_matrix((f("vals"), (f("rows").astype(np.int64), f("cols").astype(np.int64))), shape=(n, n))


def scipy_eval(K, M, B, D, S, E, sigma, dense):
    if dense:
        lam, Phi = sl.eigh(K, M, subset_by_index=[0, 29])
    else:
        lam, Phi = sla.eigsh(K, 30, M, sigma=-sigma, which="LM")
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
    lam = np.maximum(lam, 0.0)
    w = np.sqrt(lam)
    b = np.einsum("ir,ir->r", Phi, B @ Phi)
    d = np.einsum("ir,ir->r", Phi, D @ Phi)
    zeta = np.where(w > 0, b / (2 * np.where(w > 0, w, 1)), 0)
    eta = np.where(lam > 0, d / np.where(lam > 0, lam, 1), 0)
    Sp, Ep = S @ Phi, E @ Phi
    om = 2 * np.pi * 0.5 * np.arange(1000)
    den = lam[None, :] - om[:, None] ** 2 + 1j * (2 * zeta[None, :] * om[:, None] * w[None, :] + eta[None, :] * lam[None, :])
    frf = np.einsum("jr,kr,fr->fjk", Sp, Ep, 1 / den)
    return lam, frf


rows = []
with tempfile.TemporaryDirectory() as tmp:
    for name, scale, method in CASES:
        subprocess.run([BIN, "export", tmp, name.replace(" ", "_"), str(scale), method], check=True)
        d = os.path.join(tmp, name.replace(" ", "_"))
        meta = json.load(open(os.path.join(d, "meta.json")))
        K, M, B, D = (load(d, t) for t in "MKBD") if False else (load(d, "K"), load(d, "M"), load(d, "B"), load(d, "D"))
        n = meta["n"]
        S = np.fromfile(os.path.join(d, "S"), dtype="<f8").reshape(meta["sensors"], n)
        E = np.fromfile(os.path.join(d, "E"), dtype="<f8").reshape(meta["excitations"], n)
        ours_lam = np.fromfile(os.path.join(d, "eigenvalues"), dtype="<f8")
        dense = method == "dense"
        if dense:
            K, M, B, D = K.toarray(), M.toarray(), B.toarray(), D.toarray()
        best_ours, best_scipy, info = float("inf"), float("inf"), None
        for _ in range(ROUNDS):
            out = subprocess.run([BIN, "time", name, str(scale), method, "2"], check=True, capture_output=True, text=True).stdout
            info = json.loads(out.strip().splitlines()[-1])
            best_ours = min(best_ours, info["evaluation_s"])
            t = time.perf_counter()
            lam, _ = scipy_eval(K, M, B, D, S, E, meta["sigma"], dense)
            best_scipy = min(best_scipy, time.perf_counter() - t)
        dev = np.max(np.abs(np.sqrt(np.maximum(lam, 0)) / np.sqrt(np.maximum(ours_lam, 1e-300)) - 1))
        row = dict(case=name, n=n, ours_ms=best_ours * 1e3, scipy_ms=best_scipy * 1e3,
                   ratio=best_ours / best_scipy, prepare_ms=info["prepare_s"] * 1e3,
                   nnz_K=info["nnz_K"], nnz_L=info["nnz_L"], rss_mib=info["peak_rss_kib"] / 1024,
                   max_rel_freq_diff=dev)
        rows.append(row)
        print(json.dumps(row), flush=True)

print("| case | DOF | modalflow ms | scipy ms | ratio | prepare ms | nnz(K) | nnz(L) | peak RSS MiB | max |Δf/f| |")
print("|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['case']} | {r['n']} | {r['ours_ms']:.1f} | {r['scipy_ms']:.1f} | {r['ratio']:.2f} | {r['prepare_ms']:.0f} | {r['nnz_K']} | {r['nnz_L']} | {r['rss_mib']:.0f} | {r['max_rel_freq_diff']:.1e} |")
