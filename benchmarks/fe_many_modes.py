"""Many modes of solid FE models through the whole CLI against scipy/ARPACK
(issue 32, "Many modes"): the steel column 0.3 x 0.3 x 1.5 m of
`fe_free_free.py`, meshed with 8-node (its generator, imported) or 20-node
serendipity hexahedra (written here, 3x3x3 Gauss), free-free or clamped at
the base face (the base nodes' DOFs dropped from the exported matrices, as
an FE user exports a constrained model). Lowest `modes` modes by
`modalflow run` (one synthesize stage, RAYON_NUM_THREADS=1) and by
scipy.sparse.linalg.eigsh(K, modes, M, sigma=-(2 pi 100 Hz)^2,
ncv=max(2 modes + 1, 80)) after mmread of both files (OPENBLAS_NUM_THREADS=1).
CPU seconds (user+sys of the child, process_time for scipy), interleaved
best-of-n, ratios from the same run; max |df/f| over the elastic modes;
subspace MAC of every repeated pair (reference frequencies equal to 1e-6):
cos^2 of the largest principal angle between the two 2-D subspaces in the
M-inner product, from modalflow's shapes at every DOF (written by the
`fe_many_modes` bench binary, benchmarks/fe_many_modes.rs, the same solver
path) against ARPACK's.

    cargo build --release && cargo build --release --bench fe_many_modes
    /tmp/aeenv/bin/python benchmarks/fe_many_modes.py target/release/modalflow rounds \\
        elem,bc,nx,ny,nz,modes ...      # elem hex8|hex20, bc free|clamped
"""
import glob
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from itertools import product

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy.io as sio  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
BIN = os.path.abspath(sys.argv[1])
ROUNDS = int(sys.argv[2])
CASES = [s.split(",") for s in sys.argv[3:]]
# The generator and templates of fe_free_free.py, without running its main().
_src = open(os.path.join(HERE, "fe_free_free.py")).read()
_ns = {"__name__": "fe_free_free"}
_argv, sys.argv = sys.argv, [sys.argv[0], BIN]
exec(_src.replace("\nmain()\n", "\n"), _ns)
sys.argv = _argv
E, NU, RHO = _ns["E"], _ns["NU"], _ns["RHO"]
SIZE = (0.3, 0.3, 1.5)


def hex20_shapes(x, y, z):
    """Serendipity shape functions (20) of the reference cube at one point;
    natural coordinates of node a are NAT[a]."""
    out = []
    for a, b, c in NAT:
        if 0 not in (a, b, c):  # corner
            out.append((1 + a * x) * (1 + b * y) * (1 + c * z) * (a * x + b * y + c * z - 2) / 8)
        elif a == 0:
            out.append((1 - x * x) * (1 + b * y) * (1 + c * z) / 4)
        elif b == 0:
            out.append((1 + a * x) * (1 - y * y) * (1 + c * z) / 4)
        else:
            out.append((1 + a * x) * (1 + b * y) * (1 - z * z) / 4)
    return np.array(out)


NAT = [p for p in product((-1, 0, 1), repeat=3) if list(p).count(0) == (1 if 0 in p else 0)]


def hex20_element(a, b, c):
    """K and M (60 x 60, DOFs node-major x,y,z) of an a x b x c brick."""
    g, w = np.polynomial.legendre.leggauss(3)
    Ke, Me = np.zeros((60, 60)), np.zeros((60, 60))
    h = 1e-30  # complex-step derivatives of the polynomial shapes: exact
    for (x, wx), (y, wy), (z, wz) in product(zip(g, w), repeat=3):
        N = hex20_shapes(x, y, z)
        dN = np.stack([hex20_shapes(x + 1j * h, y, z).imag / h * 2 / a,
                       hex20_shapes(x, y + 1j * h, z).imag / h * 2 / b,
                       hex20_shapes(x, y, z + 1j * h).imag / h * 2 / c], axis=1)
        _ns["add_gauss_point"](Ke, Me, N, dN, a * b * c / 8 * wx * wy * wz)
    return Ke, Me


def assemble_hex20(nx, ny, nz):
    """Hex20 mesh on a doubled grid: a node at every grid point with at most
    one odd coordinate (corners: none, mid-edge: one). Returns K, M and the
    node's z grid index per DOF (0: base face)."""
    G = (2 * nx + 1, 2 * ny + 1, 2 * nz + 1)
    gi, gj, gk = np.meshgrid(*[np.arange(s) for s in G], indexing="ij")
    keep = (gi % 2 + gj % 2 + gk % 2) <= 1
    number = -np.ones(G, int)
    number[keep] = np.arange(keep.sum())
    Ke, Me = hex20_element(SIZE[0] / nx, SIZE[1] / ny, SIZE[2] / nz)
    i, j, k = [v.ravel() for v in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")]
    nodes = np.stack([number[2 * i + 1 + a, 2 * j + 1 + b, 2 * k + 1 + c] for a, b, c in NAT], 1)
    dofs = (3 * nodes[:, :, None] + np.arange(3)).reshape(len(i), 60)
    rows = np.repeat(dofs, 60, axis=1).ravel()
    cols = np.tile(dofs, (1, 60)).ravel()
    n = 3 * keep.sum()
    K = sp.coo_matrix((np.tile(Ke.ravel(), len(i)), (rows, cols)), shape=(n, n)).tocsc()
    M = sp.coo_matrix((np.tile(Me.ravel(), len(i)), (rows, cols)), shape=(n, n)).tocsc()
    return K, M, np.repeat(gk[keep], 3)


def model(elem, nx, ny, nz, bc):
    if elem == "hex20":
        K, M, level = assemble_hex20(nx, ny, nz)
    else:
        K, M = _ns["assemble"](nx, ny, nz)
        level = np.repeat(np.arange(K.shape[0] // 3) // ((nx + 1) * (ny + 1)), 3)
    # Known answers of the generator: rigid translations carry no force,
    # and M sums to the column's mass in each direction.
    t = np.zeros(K.shape[0])
    t[0::3] = 1
    assert np.abs(K @ t).max() < 1e-6 * abs(K).max(), "rigid translation strains"
    assert abs(t @ M @ t / (RHO * np.prod(SIZE)) - 1) < 1e-12, "mass"
    if bc == "clamped":
        free = np.flatnonzero(level > 0)
        K, M = K[free][:, free].tocsc(), M[free][:, free].tocsc()
    return K, M


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def bench_binary():
    root = os.path.dirname(HERE)
    exe = [p for p in glob.glob(os.path.join(root, "target/release/deps/fe_many_modes-*"))
           if os.access(p, os.X_OK) and not p.endswith(".d")]
    return max(exe, key=os.path.getmtime) if exe else None


def pair_macs(lam, X, Phi, M, rigid):
    """cos^2 of the largest principal angle (M-inner product) between the
    reference and modalflow subspaces of each repeated pair."""
    f = np.sqrt(np.clip(lam, 0, None))
    out = []
    r = rigid
    while r + 1 < len(f):
        if abs(f[r + 1] / f[r] - 1) < 1e-6:
            C = X[:, r:r + 2].T @ (M @ Phi[:, r:r + 2])
            out.append(np.linalg.svd(C, compute_uv=False).min() ** 2)
            r += 2
        else:
            r += 1
    return out


def main():
    print("| elements | support | DOF | modes | modalflow run CPU s | scipy read + eigsh CPU s | ratio "
          "| max abs(df/f) | repeated pairs: min subspace MAC | top mode Hz |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    bench = bench_binary()
    for elem, bc, nx, ny, nz, modes in CASES:
        nx, ny, nz, modes = int(nx), int(ny), int(nz), int(modes)
        K, M = model(elem, nx, ny, nz, bc)
        n = K.shape[0]
        rigid = 6 if bc == "free" else 0
        d = tempfile.mkdtemp()
        sio.mmwrite(os.path.join(d, "k.mtx"), sp.tril(K), symmetry="symmetric", precision=17)
        sio.mmwrite(os.path.join(d, "m.mtx"), sp.tril(M), symmetry="symmetric", precision=17)
        open(os.path.join(d, "p.yaml"), "w").write(_ns["PIPELINE"].replace("modes: 30", f"modes: {modes}"))
        open(os.path.join(d, "model.yaml"), "w").write(_ns["MODEL"].format(solver="{method: sparse}"))
        best_mf, best_sp = np.inf, np.inf
        for _ in range(ROUNDS):
            for sub in ("cache", "results"):
                shutil.rmtree(os.path.join(d, sub), ignore_errors=True)
            t = cpu_children()
            p = subprocess.run([BIN, "run", "p.yaml"], cwd=d, capture_output=True, text=True,
                               env=dict(os.environ, RAYON_NUM_THREADS="1"))
            best_mf = min(best_mf, cpu_children() - t)
            if p.returncode != 0:
                sys.exit(p.stderr[-400:])
            t = time.process_time()
            Kr = sio.mmread(os.path.join(d, "k.mtx")).tocsc()
            Mr = sio.mmread(os.path.join(d, "m.mtx")).tocsc()
            lam, X = sla.eigsh(Kr, modes, Mr, sigma=-(2 * np.pi * 100) ** 2, which="LM",
                               ncv=max(2 * modes + 1, 80))
            best_sp = min(best_sp, time.process_time() - t)
        order = np.argsort(lam)
        lam, X = lam[order], X[:, order]
        rows = open(os.path.join(d, "results/ff/truth/modes/modes.csv")).read().splitlines()[1:]
        f = np.array([float(r.split(",")[3]) for r in rows])
        fr = np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)
        err = np.max(np.abs(f[rigid:] / fr[rigid:] - 1))
        mac = "n/a"
        if bench:
            out = os.path.join(d, "phi.bin")
            subprocess.run([bench, os.path.join(d, "model.yaml"), str(modes), "1", out], check=True,
                           capture_output=True, env=dict(os.environ, RAYON_NUM_THREADS="1"))
            raw = np.fromfile(out, dtype="<f8")
            Phi = raw[modes:].reshape(modes, n).T
            macs = pair_macs(lam, X, Phi, Mr, rigid)
            mac = f"{len(macs)}: {min(macs):.9f}" if macs else "none"
        print(f"| {elem} | {bc} | {n:,} | {modes} | {best_mf:.2f} | {best_sp:.2f} | {best_mf / best_sp:.2f} "
              f"| {err:.1e} | {mac} | {f[-1]:.0f} |", flush=True)
        shutil.rmtree(d)


main()
