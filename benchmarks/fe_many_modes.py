"""Many modes of a free-free solid through the whole CLI against
scipy/ARPACK (issue 32, "Many modes"): the hex8 steel column of
`fe_free_free.py` (same generator, imported from it), lowest `modes`
modes by `modalflow run` (one synthesize stage, RAYON_NUM_THREADS=1) and by
scipy.sparse.linalg.eigsh(K, modes, M, sigma=-(2 pi 100 Hz)^2,
ncv=max(2 modes + 1, 80)) after mmread of both files
(OPENBLAS_NUM_THREADS=1). CPU seconds (user+sys), interleaved best-of-n;
max |df/f| over the elastic modes (the first six are rigid-body).

    cargo build --release
    /tmp/aeenv/bin/python benchmarks/fe_many_modes.py target/release/modalflow rounds nx,ny,nz,modes ...
"""
import os
import shutil
import subprocess
import sys
import tempfile
import time
import resource

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy.io as sio  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

BIN = os.path.abspath(sys.argv[1])
ROUNDS = int(sys.argv[2])
CASES = [tuple(int(x) for x in s.split(",")) for s in sys.argv[3:]]
# The generator and templates of fe_free_free.py, without running its main().
_src = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fe_free_free.py")).read()
_ns = {"__name__": "fe_free_free"}
_argv, sys.argv = sys.argv, [sys.argv[0], BIN]
exec(_src.replace("\nmain()\n", "\n"), _ns)
sys.argv = _argv


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


print("| DOF | modes | modalflow run CPU s | scipy read + eigsh CPU s | ratio | max abs(df/f) elastic | top mode Hz |")
print("|---|---|---|---|---|---|---|")
for nx, ny, nz, modes in CASES:
    K, M = _ns["assemble"](nx, ny, nz)
    n = K.shape[0]
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
        lam = sla.eigsh(Kr, modes, Mr, sigma=-(2 * np.pi * 100) ** 2, which="LM",
                        ncv=max(2 * modes + 1, 80))[0]
        best_sp = min(best_sp, time.process_time() - t)
    rows = open(os.path.join(d, "results/ff/truth/modes/modes.csv")).read().splitlines()[1:]
    f = np.array([float(r.split(",")[3]) for r in rows])
    fr = np.sqrt(np.clip(np.sort(lam), 0, None)) / (2 * np.pi)
    err = np.max(np.abs(f[6:] / fr[6:] - 1))
    print(f"| {n:,} | {modes} | {best_mf:.2f} | {best_sp:.2f} | {best_mf / best_sp:.2f} | {err:.1e} | {f[-1]:.0f} |")
    shutil.rmtree(d)
