#!/usr/bin/env python3
"""Side by side with the published PUB5 code (PyPI `autoema`) on the same FRFs.

modalflow synthesizes the three-mass system's FRFs (1 % noise, one reference,
three responses), exports them as CSV and runs its `autoema` stage; the script
then runs AutoEMA's `OptModel` on the same CSV with the same number of
Bayesian-optimization evaluations, and compares wall time, modes found (NFD
to the true modes) and mean FRAC.

Set-up (PyPI AutoEMA 0.0 predates scikit-learn 1.4, which renamed
AgglomerativeClustering's `affinity=` to `metric=`):

    python3 -m venv /tmp/aeenv
    /tmp/aeenv/bin/pip install numpy scipy scikit-learn "bayesian-optimization<2" sdypy-ema
    /tmp/aeenv/bin/pip install --no-deps autoema
    sed -i "s/affinity='l1'/metric='l1'/" /tmp/aeenv/lib/python3.11/site-packages/AutoEMA/AutoEMA.py
    cargo build --release
    /tmp/aeenv/bin/python benchmarks/autoema_compare.py --modalflow target/release/modalflow
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np

PIPELINE = """name: cmp
seed: 3
stages:
  truth:
    kind: synthesize
    params: {{model: three_mass.yaml, frequency: {{min: 0, max: 400, step: 0.25}}, noise: {{relative: {noise}}}}}
  csv:
    kind: export
    inputs: {{frf: truth.frf}}
    params: {{format: csv}}
  ema:
    kind: autoema
    inputs: {{frf: truth.frf}}
    params: {{band: [{low}, 400], iterations: {evals}, initial: {init}}}
"""


def read_frf_csv(path):
    with open(path) as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))]
    header, data = rows[0], np.array(rows[1:], dtype=float)
    f_axis = data[:, header.index("frequency_hz")]
    channels = [h[3:] for h in header if h.startswith("re:")]
    frf = np.array([data[:, header.index("re:" + c)] + 1j * data[:, header.index("im:" + c)] for c in channels])
    return frf, f_axis


def score(found, truth):
    """(modes within 1 % of a true mode, max NFD of those, spurious modes)."""
    hits, nfds = 0, []
    for t in truth:
        if len(found) == 0:
            continue
        near = min(found, key=lambda f: abs(f - t))
        nfd = abs(near - t) / min(near, t)
        if nfd < 0.01:
            hits += 1
            nfds.append(nfd)
    spurious = sum(1 for f in found if min(abs(f - t) / t for t in truth) > 0.01)
    return hits, (max(nfds) if nfds else float("nan")), spurious


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--modalflow", default="target/release/modalflow")
    ap.add_argument("--evaluations", type=int, default=40)
    ap.add_argument("--initial", type=int, default=20)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--low", type=float, default=5.0)
    a = ap.parse_args()
    from AutoEMA import AutoEMA as ae

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with tempfile.TemporaryDirectory() as d:
        shutil.copy(os.path.join(root, "pipelines/models/three_mass.yaml"), d)
        with open(os.path.join(d, "p.yaml"), "w") as f:
            f.write(PIPELINE.format(noise=a.noise, low=a.low, evals=a.evaluations, init=a.initial))
        t = time.perf_counter()
        subprocess.run([os.path.abspath(a.modalflow), "run", "p.yaml", "--progress", "none"], cwd=d, check=True, stdout=subprocess.DEVNULL)
        mf_wall = time.perf_counter() - t
        res = os.path.join(d, "results/cmp")
        mf_seconds = json.load(open(os.path.join(res, "ema/manifest.json")))["seconds"]
        truth = [float(r["frequency_hz"]) for r in csv.DictReader(open(os.path.join(res, "truth/modes/modes.csv")))]
        mf_modes = [float(r["frequency_hz"]) for r in csv.DictReader(open(os.path.join(res, "ema/modes/modes.csv")))]
        mf_frac = json.load(open(os.path.join(res, "ema/metrics.json")))["mean_frac"]
        frf, f_axis = read_frf_csv(os.path.join(res, "csv/export/frf.csv"))

    keep = f_axis >= a.low
    t = time.perf_counter()
    model = ae.OptModel(frf=frf[:, keep], f_axis=f_axis[keep], show_progress=False)
    model.optimize(n_init=a.initial, n_iter=a.evaluations - a.initial)
    ae_seconds = time.perf_counter() - t
    _, _, nat, _, _ = model.get_results()
    ae_modes = sorted(float(x) for x in np.atleast_1d(nat))
    ae_frac = float(model.get_frac())

    print(f"three-mass system, {a.noise:.0%} noise, {frf.shape[0]} FRFs x {keep.sum()} lines, "
          f"{a.evaluations} BO evaluations each; true modes {', '.join(f'{t:.2f}' for t in truth)} Hz")
    print(f"{'':<22}{'seconds':>10}{'modes found':>13}{'max NFD':>10}{'spurious':>10}{'mean FRAC':>11}")
    for name, secs, modes, frac in [("AutoEMA (PyPI, PUB5)", ae_seconds, ae_modes, ae_frac), ("modalflow autoema", mf_seconds, mf_modes, mf_frac)]:
        hits, nfd, spur = score(modes, truth)
        print(f"{name:<22}{secs:>10.3f}{f'{hits}/{len(truth)}':>13}{nfd:>10.2e}{spur:>10}{frac:>11.5f}")
    print(f"speed-up: {ae_seconds / mf_seconds:.0f}x (modalflow pipeline wall time incl. synthesis and export: {mf_wall:.2f} s)")


if __name__ == "__main__":
    main()
