#!/usr/bin/env python3
"""Side-by-side with DVC on the same 200-stage pipeline as benchmarks/engine.rs.

Times (best of N) a fully cached `run`/`repro` and `status` for modalflow and DVC
in one script, on the same machine, so the ratio is meaningful.

    python3 -m venv /tmp/dvcenv && /tmp/dvcenv/bin/pip install dvc
    cargo build --release
    python3 benchmarks/dvc_compare.py --dvc /tmp/dvcenv/bin/dvc --modalflow target/release/modalflow
"""
import argparse
import os
import subprocess
import tempfile
import time


def groups():
    """(name, deps, out) for 20 groups of source, chain of 4, fan-out of 4, join."""
    for g in range(20):
        src = f"g{g}_src.txt"
        yield f"g{g}_src", [], src
        prev = src
        for c in range(4):
            out = f"g{g}_c{c}.txt"
            yield f"g{g}_c{c}", [prev], out
            prev = out
        fans = []
        for f in range(4):
            out = f"g{g}_f{f}.txt"
            yield f"g{g}_f{f}", [prev], out
            fans.append(out)
        yield f"g{g}_join", fans, f"g{g}_join.txt"


def cmd(name, deps, out):
    cat = f"cat {' '.join(deps)}" if deps else "echo seed"
    return f"{cat} > {out}; echo {name} >> {out}"


def write_modalflow(d):
    lines = ["name: bench200", "stages:"]
    for name, deps, out in groups():
        dep = f", deps: [{', '.join(deps)}]" if deps else ""
        lines += [f"  {name}:", "    kind: command", f'    params: {{cmd: "{cmd(name, deps, out)}"{dep}, outs: [{out}]}}']
    open(os.path.join(d, "p.yaml"), "w").write("\n".join(lines) + "\n")


def write_dvc(d):
    lines = ["stages:"]
    for name, deps, out in groups():
        lines += [f"  {name}:", f'    cmd: "{cmd(name, deps, out)}"']
        if deps:
            lines.append("    deps: [" + ", ".join(deps) + "]")
        lines.append(f"    outs: [{out}]")
    open(os.path.join(d, "dvc.yaml"), "w").write("\n".join(lines) + "\n")


def best(argv, cwd, reps):
    t_best = float("inf")
    for _ in range(reps):
        t = time.perf_counter()
        subprocess.run(argv, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t_best = min(t_best, time.perf_counter() - t)
    return t_best * 1e3


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dvc", default="dvc")
    ap.add_argument("--modalflow", default="target/release/modalflow")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    mf = os.path.abspath(a.modalflow)
    with tempfile.TemporaryDirectory() as m, tempfile.TemporaryDirectory() as v:
        write_modalflow(m)
        subprocess.run([mf, "run", "p.yaml", "--progress", "none"], cwd=m, check=True, stdout=subprocess.DEVNULL)
        write_dvc(v)
        subprocess.run([a.dvc, "init", "--no-scm", "-q"], cwd=v, check=True)
        subprocess.run([a.dvc, "repro", "-q"], cwd=v, check=True, stdout=subprocess.DEVNULL)
        rows = [
            ("startup", best([mf, "--version"], m, a.reps), best([a.dvc, "--version"], v, a.reps)),
            ("status", best([mf, "status", "p.yaml"], m, a.reps), best([a.dvc, "status"], v, a.reps)),
            ("cached run / repro", best([mf, "run", "p.yaml", "--progress", "none"], m, a.reps), best([a.dvc, "repro"], v, a.reps)),
        ]
    print(f"200-stage pipeline, best of {a.reps} (ms)")
    print(f"{'':<22}{'modalflow':>12}{'dvc':>12}{'dvc/modalflow':>16}")
    for name, x, y in rows:
        print(f"{name:<22}{x:>12.1f}{y:>12.1f}{y / x:>16.1f}")


if __name__ == "__main__":
    main()
