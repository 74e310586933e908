"""Free-free solid FE model through the whole CLI against scipy/ARPACK
(issue 32): a steel column 0.3 x 0.3 x 1.5 m meshed with 8-node hexahedra
(consistent mass, 2x2x2 Gauss, written here with numpy), exported as Matrix
Market, solved by `modalflow run` (a synthesize stage, lowest 30 modes)
with the shift chosen from the problem and with a fixed 1 Hz shift, and by
scipy.sparse.linalg.eigsh(K, 30, M, sigma=-(2 pi 100 Hz)^2) (ARPACK
shift-invert on a SuperLU factor) on the same matrices.

Prints per size: DOF, modalflow process CPU seconds (user+sys of the whole
`run`, one thread: RAYON_NUM_THREADS=1), scipy read + eigsh CPU seconds
(OPENBLAS_NUM_THREADS=1), max |df/f| of the 24 elastic modes, and what the
fixed 1 Hz shift gives (an error from the residual check, or its max
|df/f|). Interleaved best-of-n.

    cargo build --release
    /tmp/aeenv/bin/python benchmarks/fe_free_free.py target/release/modalflow [rounds] [nx,ny,nz ...]
"""
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy.io as sio  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

BIN = os.path.abspath(sys.argv[1])
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 2
SIZES = [tuple(int(x) for x in s.split(",")) for s in sys.argv[3:]] or [(6, 6, 30), (10, 10, 50)]
E, NU, RHO = 2.1e11, 0.3, 7850.0
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)


def add_gauss_point(Ke, Me, N, dN, det):
    """Add one Gauss point's isotropic stiffness and consistent mass
    (shape values N, physical derivatives dN: nodes x 3, weight det) to the
    element matrices (DOFs node-major x, y, z)."""
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    for i in range(3):
        Me[i::3, i::3] += RHO * np.outer(N, N) * det
        for j in range(3):
            k = lam * np.outer(dN[:, i], dN[:, j]) + mu * np.outer(dN[:, j], dN[:, i])
            if i == j:
                k += mu * dN @ dN.T
            Ke[i::3, j::3] += k * det


def element(a, b, c):
    g = 1 / np.sqrt(3)
    det = a * b * c / 8
    Ke, Me = np.zeros((24, 24)), np.zeros((24, 24))
    for x in (-g, g):
        for y in (-g, g):
            for z in (-g, g):
                u = 1 + x * CORNERS[:, 0]
                v = 1 + y * CORNERS[:, 1]
                w = 1 + z * CORNERS[:, 2]
                N = u * v * w / 8
                dN = np.stack([CORNERS[:, 0] * v * w / 8 * 2 / a,
                               CORNERS[:, 1] * u * w / 8 * 2 / b,
                               CORNERS[:, 2] * u * v / 8 * 2 / c], axis=1)
                add_gauss_point(Ke, Me, N, dN, det)
    return Ke, Me


def assemble(nx, ny, nz, size=(0.3, 0.3, 1.5)):
    a, b, c = size[0] / nx, size[1] / ny, size[2] / nz
    Ke, Me = element(a, b, c)
    node = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)  # noqa: E731
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    nodes = np.stack([node(i + (cx > 0), j + (cy > 0), k + (cz > 0)) for cx, cy, cz in CORNERS], 1)
    dofs = (3 * nodes[:, :, None] + np.arange(3)).reshape(len(i), 24)
    rows = np.repeat(dofs, 24, axis=1).ravel()
    cols = np.tile(dofs, (1, 24)).ravel()
    n = 3 * (nx + 1) * (ny + 1) * (nz + 1)
    K = sp.coo_matrix((np.tile(Ke.ravel(), len(i)), (rows, cols)), shape=(n, n)).tocsc()
    M = sp.coo_matrix((np.tile(Me.ravel(), len(i)), (rows, cols)), shape=(n, n)).tocsc()
    return K, M


MODEL = """parameters: []
bodies:
  - name: column
    superelement:
      mass: m.mtx
      stiffness: k.mtx
      nodes:
        - {{id: 1, dofs: [0, 1, 2], position: [0, 0, 0]}}
      points: {{a: {{node: 1}}}}
sensors: [{{name: s, body: column, point: a, node: 1, direction: 1}}]
excitations: [{{name: s, body: column, point: a, node: 1, direction: 1}}]
solver: {solver}
"""
PIPELINE = """name: ff
stages:
  truth:
    kind: synthesize
    params: {model: model.yaml, frequency: {min: 0, max: 40000, step: 40}, modes: 30}
"""


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_modalflow(d, solver):
    open(os.path.join(d, "model.yaml"), "w").write(MODEL.format(solver=solver))
    shutil.rmtree(os.path.join(d, "cache"), ignore_errors=True)
    shutil.rmtree(os.path.join(d, "results"), ignore_errors=True)
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    t = cpu_children()
    p = subprocess.run([BIN, "run", "p.yaml"], cwd=d, env=env, capture_output=True, text=True)
    cpu = cpu_children() - t
    if p.returncode != 0:
        return cpu, None, p.stderr.strip().splitlines()[-1][:160]
    rows = open(os.path.join(d, "results/ff/truth/modes/modes.csv")).read().splitlines()[1:]
    f = np.array([float(r.split(",")[3]) for r in rows])
    return cpu, f, None


def main():
    print("| DOF | modalflow run CPU s | scipy read + eigsh CPU s | ratio | max abs(df/f) elastic | fixed 1 Hz shift |")
    print("|---|---|---|---|---|---|")
    for nx, ny, nz in SIZES:
        K, M = assemble(nx, ny, nz)
        n = K.shape[0]
        d = tempfile.mkdtemp()
        sio.mmwrite(os.path.join(d, "k.mtx"), sp.tril(K), symmetry="symmetric", precision=17)
        sio.mmwrite(os.path.join(d, "m.mtx"), sp.tril(M), symmetry="symmetric", precision=17)
        open(os.path.join(d, "p.yaml"), "w").write(PIPELINE)
        best_mf, best_sp = np.inf, np.inf
        for _ in range(ROUNDS):
            cpu, f, err = run_modalflow(d, "{method: sparse}")
            best_mf = min(best_mf, cpu)
            t = time.process_time()
            Kr = sio.mmread(os.path.join(d, "k.mtx")).tocsc()
            Mr = sio.mmread(os.path.join(d, "m.mtx")).tocsc()
            lam = sla.eigsh(Kr, 30, Mr, sigma=-(2 * np.pi * 100) ** 2, which="LM", ncv=80,
                            return_eigenvectors=True)[0]
            best_sp = min(best_sp, time.process_time() - t)
        fr = np.sqrt(np.clip(np.sort(lam), 0, None)) / (2 * np.pi)
        acc = err or f"{np.max(np.abs(f[6:] / fr[6:] - 1)):.1e}"
        _, f1, err1 = run_modalflow(d, "{method: sparse, shift: 1}")
        fixed = f"error: {err1}" if err1 else f"{np.max(np.abs(f1[6:] / fr[6:] - 1)):.1e}"
        print(f"| {n:,} | {best_mf:.2f} | {best_sp:.2f} | {best_mf / best_sp:.2f} | {acc} | {fixed} |")
        shutil.rmtree(d)


main()
