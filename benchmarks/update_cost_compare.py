#!/usr/bin/env python3
"""Cost of one model update under two modalflow builds, as a ratio.

Each build gets its own copy of `pipelines/` (its own cache: the two builds
may carry the same stage version with different numbers), runs what the
stage needs once, then recomputes the stage (`--force`) round by round, the
two builds interleaved (the machine is shared). Per build: the best and
median child CPU time and wall time, and the stage's evaluations and
verdict from its cost.json, so a speed-up that changed the result shows.

    python3 benchmarks/update_cost_compare.py BEFORE AFTER \\
        [--stage 'measured_hammer[s=10]'] \\
        [--pipeline model_updating_families.yaml] [--rounds 3] [--jobs 1]

Measured for identify 34 (normal equations by one blocked product, no refit
at the noise floor, the FRF superposition's mode count guessed): see
docs/uncertainty.md, "Cheaper updates, identify 34".
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def workspace(tag):
    """A fresh copy of the repository's pipelines for one build."""
    root = tempfile.mkdtemp(prefix=f"modalflow-update-{tag}-")
    shutil.copytree(os.path.join(REPO, "pipelines"), os.path.join(root, "pipelines"))
    open(os.path.join(root, "pipelines", ".modalflow"), "w").close()
    return os.path.join(root, "pipelines")


def run(binary, cwd, pipeline, stage, jobs, force):
    """One run; returns (cpu seconds of the child, wall seconds)."""
    cmd = [binary, "run", pipeline, stage, "--progress", "none", "-j", str(jobs)]
    if force:
        cmd += ["--force", stage.split("[")[0]]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime, wall


def outcome(cwd, pipeline, stage):
    """Evaluations, FRF RMS and verdict of the stage's cost.json."""
    name = os.path.splitext(os.path.basename(pipeline))[0]
    path = os.path.join(cwd, "results", name, stage, "cost.json")
    with open(path) as f:
        d = json.load(f)
    v = d.get("verdict") or {}
    rms = (v.get("frf") or {}).get("end", {}).get("rms", v.get("end_rms"))
    return d["evaluations"], rms, v.get("ok"), v.get("cause")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--stage", default="measured_hammer[s=10]")
    ap.add_argument("--pipeline", default="model_updating_families.yaml")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args()
    builds = [("before", os.path.abspath(a.before)), ("after", os.path.abspath(a.after))]
    dirs = {}
    for tag, binary in builds:
        dirs[tag] = workspace(tag)
        run(binary, dirs[tag], a.pipeline, a.stage, 2, False)
    cpu = {t: [] for t, _ in builds}
    wall = {t: [] for t, _ in builds}
    for _ in range(a.rounds):
        for tag, binary in builds:
            c, w = run(binary, dirs[tag], a.pipeline, a.stage, a.jobs, True)
            cpu[tag].append(c)
            wall[tag].append(w)
    for tag, binary in builds:
        ev, rms, ok, cause = outcome(dirs[tag], a.pipeline, a.stage)
        print(
            f"{tag} ({binary}): CPU best {min(cpu[tag]):.1f} s, median "
            f"{statistics.median(cpu[tag]):.1f} s; wall best {min(wall[tag]):.1f} s; "
            f"{ev} evaluations, FRF {rms:.3f}σ, ok {ok}, cause {cause}"
        )
    print(
        f"after / before: CPU best {min(cpu['after']) / min(cpu['before']):.2f}, "
        f"wall best {min(wall['after']) / min(wall['before']):.2f}"
    )
    for d in dirs.values():
        shutil.rmtree(os.path.dirname(d))


if __name__ == "__main__":
    main()
