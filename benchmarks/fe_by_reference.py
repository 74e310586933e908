"""Large FE matrices by reference (issue 32): what a Matrix Market model
costs modalflow outside the solve. The free-free hex8 steel column of
fe_free_free.py (imported, numpy generator) is exported with scipy's mmwrite
(lower triangle, 17 digits) and run through one synthesize stage (30 modes).

Prints per size and per binary (`BIN`, optionally a `BEFORE` build to
compare): DOF, matrix text MB, `modalflow validate` CPU s, a fully cached
`modalflow run` CPU s (best of ROUNDS, user+sys of the whole process),
model.json bytes, cache bytes after the first run; and the Matrix Market
reader alone against scipy.io.mmread on the same two files (CPU s and wall
s; modalflow's through `fe_setup_costs read`, the bench binary READER that
`cargo bench --bench fe_setup_costs --no-run` prints).

    cargo build --release && cargo bench --bench fe_setup_costs --no-run
    /tmp/aeenv/bin/python benchmarks/fe_by_reference.py target/release/modalflow \\
        target/release/deps/fe_setup_costs-HASH [--before OLD_BIN] [--rounds 3] 8,8,40 20,20,145
"""
import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import scipy.io as sio  # noqa: E402
import scipy.sparse as sp  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("bin")
ap.add_argument("reader")
ap.add_argument("sizes", nargs="+")
ap.add_argument("--before")
ap.add_argument("--rounds", type=int, default=3)
args = ap.parse_args()

# The generator and templates of fe_free_free.py, without running its main().
_src = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fe_free_free.py")).read()
_ns = {"__name__": "fe_free_free"}
_argv, sys.argv = sys.argv, [sys.argv[0], args.bin]
exec(_src.replace("\nmain()\n", "\n"), _ns)
sys.argv = _argv


def cpu_of(cmd, cwd, env=None):
    """CPU seconds (user+sys) and wall seconds of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.time()
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.time() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"{cmd}: {p.stderr.strip()[-400:]}")
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, wall


def du(path):
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(path) for f in fs)


def stage_costs(binary, d):
    """First run (fills the cache), then best-of validate and cached run."""
    for sub in ("cache", "results"):
        shutil.rmtree(os.path.join(d, sub), ignore_errors=True)
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    first, _ = cpu_of([binary, "run", "p.yaml", "--progress", "none"], d, env)
    validate = min(cpu_of([binary, "validate", "p.yaml"], d, env)[0] for _ in range(args.rounds))
    cached = min(cpu_of([binary, "run", "p.yaml", "--progress", "none"], d, env)[0]
                 for _ in range(args.rounds))
    model_json = os.path.getsize(os.path.join(d, "results/ff/truth/model.json"))
    return first, validate, cached, model_json, du(os.path.join(d, "cache"))


def reader(d):
    """modalflow's reader and scipy's mmread on k.mtx + m.mtx: CPU s, wall s."""
    files = [os.path.join(d, f) for f in ("k.mtx", "m.mtx")]
    out = {}
    for threads in ("1", "2"):
        env = dict(os.environ, RAYON_NUM_THREADS=threads)
        runs = []
        for _ in range(args.rounds):
            cpu = wall = 0.0
            for f in files:
                c, w = cpu_of([args.reader, "read", f], d, env)
                cpu, wall = cpu + c, wall + w
            runs.append((cpu, wall))
        out[f"modalflow {threads} thread(s)"] = min(runs)
    runs = []
    for _ in range(args.rounds):
        t, c = time.time(), time.process_time()
        for f in files:
            sio.mmread(f)
        runs.append((time.process_time() - c, time.time() - t))
    out["scipy mmread"] = min(runs)
    return out


def main():
    bins = [("this build", args.bin)] + ([("before", args.before)] if args.before else [])
    print("| DOF | matrix text MB | build | validate CPU s | cached run CPU s | first run CPU s "
          "| model.json bytes | cache bytes |")
    print("|---|---|---|---|---|---|---|---|")
    readers = []
    for size in args.sizes:
        nx, ny, nz = (int(x) for x in size.split(","))
        K, M = _ns["assemble"](nx, ny, nz)
        n = K.shape[0]
        d = tempfile.mkdtemp(dir=os.environ.get("BENCH_DIR"))
        sio.mmwrite(os.path.join(d, "k.mtx"), sp.tril(K), symmetry="symmetric", precision=17)
        sio.mmwrite(os.path.join(d, "m.mtx"), sp.tril(M), symmetry="symmetric", precision=17)
        del K, M
        text_mb = (du(d)) / 1e6
        open(os.path.join(d, "model.yaml"), "w").write(_ns["MODEL"].format(solver="{method: sparse}"))
        open(os.path.join(d, "p.yaml"), "w").write(_ns["PIPELINE"])
        for label, binary in bins:
            first, validate, cached, mj, cache = stage_costs(binary, d)
            print(f"| {n:,} | {text_mb:.0f} | {label} | {validate:.2f} | {cached:.2f} | {first:.1f} "
                  f"| {mj:,} | {cache:,} |", flush=True)
        readers.append((n, text_mb, reader(d)))
        shutil.rmtree(d)
    print()
    print("| DOF | matrix text MB | reader | CPU s | wall s |")
    print("|---|---|---|---|---|")
    for n, mb, r in readers:
        for name, (cpu, wall) in r.items():
            print(f"| {n:,} | {mb:.0f} | {name} | {cpu:.2f} | {wall:.2f} |")


main()
