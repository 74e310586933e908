#!/usr/bin/env python3
"""pyuff reads every universal file modalflow writes, with the values of
modalflow's own CSV exports.

Runs a small study (three-mass model: exact FRFs, mass-normalized modes, and
AutoEMA's complex modes) whose `export` stages write the same data as UFF 58
ASCII + 55, as UFF 58b + 55 and as CSV; then reads every UFF with pyuff
(installed into a virtual environment here, never a test dependency) and
compares it with the CSVs:

- datasets 58/58b: frequencies and complex FRF values (relative to each
  FRF's largest value; ASCII keeps 13 digits in 4E20.12, 58b is exact);
- dataset 55: frequency, damping and shapes to the 7 digits of E13.6 (the
  dataset's 13-column fields, which pyuff cuts by column), modal mass 1 for
  the mass-normalized truth, modal A = 2j·Im(λ) for complex modes of known
  scale, 0 otherwise; modalflow's own reader gets frequency and damping
  exactly from ID line 5.

    python3 benchmarks/pyuff_roundtrip.py [--venv DIR]

Exit code 0 when every comparison holds; prints one line per file.
"""
import argparse
import csv
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

PIPELINE = """name: pyuff_roundtrip
seed: 3
stages:
  truth:
    kind: synthesize
    params:
      model: {model}
      frequency: {{min: 0, max: 400, step: 0.5}}
  noisy:
    kind: synthesize
    params:
      model: {model}
      frequency: {{min: 0, max: 400, step: 0.5}}
      noise: {{relative: 0.01}}
  ema:
    kind: autoema
    inputs: {{frf: noisy.frf}}
    params: {{max_order: [6, 20], iterations: 6, initial: 6}}
  uff:
    kind: export
    inputs: {{frf: truth.frf, modes: truth.modes}}
    params: {{format: uff}}
  uffb:
    kind: export
    inputs: {{frf: noisy.frf, modes: truth.modes}}
    params: {{format: uff-binary}}
  csv_truth:
    kind: export
    inputs: {{frf: truth.frf, modes: truth.modes}}
    params: {{format: csv}}
  csv_noisy:
    kind: export
    inputs: {{frf: noisy.frf}}
    params: {{format: csv}}
  ema_uff:
    kind: export
    inputs: {{modes: ema.modes}}
  ema_csv:
    kind: export
    inputs: {{modes: ema.modes}}
    params: {{format: csv}}
"""


def venv_python(venv):
    py = os.path.join(venv, "bin", "python")
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", venv])
        subprocess.check_call([py, "-m", "pip", "install", "-q", "pyuff", "numpy"])
    return py


READER = r"""
import json, sys, pyuff
out = []
for ds in pyuff.UFF(sys.argv[1]).read_sets():
    ds = ds if isinstance(ds, dict) else ds
    t = ds['type']
    if t == 58:
        out.append({'type': 58, 'func': int(ds['func_type']),
                    'rsp': [int(ds['rsp_node']), int(ds['rsp_dir'])],
                    'ref': [int(ds['ref_node']), int(ds['ref_dir'])],
                    'load_case': int(ds.get('load_case_id', 0)),
                    'x': [float(v) for v in ds['x']],
                    're': [float(complex(v).real) for v in ds['data']],
                    'im': [float(complex(v).imag) for v in ds['data']]})
    elif t == 55:
        d = {'type': 55, 'analysis': int(ds['analysis_type']),
             'data_type': int(ds['data_type']), 'mode': int(ds['mode_n']),
             'load_case': int(ds['load_case']),
             'nodes': [int(n) for n in ds['node_nums']]}
        for k in ('r1', 'r2', 'r3'):
            d[k] = [[complex(v).real, complex(v).imag] for v in ds[k]]
        if d['analysis'] == 2:
            d.update(freq=float(ds['freq']), modal_m=float(ds['modal_m']),
                     zeta=float(ds['modal_damp_vis']))
        else:
            e, a = complex(ds['eig']), complex(ds['modal_a'])
            d.update(eig=[e.real, e.imag], modal_a=[a.real, a.imag])
        out.append(d)
json.dump(out, sys.stdout)
"""


def pyuff_read(py, path):
    import json
    text = subprocess.check_output([py, "-c", READER, path])
    return json.loads(text)


def read_frf_csv(path):
    """(position, freq) rows → {(pos, channel): [(f, re, im)]}."""
    rows = [r for r in open(path) if not r.startswith("#")]
    rdr = csv.DictReader(rows)
    out = {}
    for r in rdr:
        pos = int(r.get("position") or 0)
        for k, v in r.items():
            if k.startswith("re:") and v != "":
                ch = k[3:]
                out.setdefault((pos, ch), []).append(
                    (float(r["frequency_hz"]), float(v), float(r["im:" + ch])))
    return out


def dof_text(node, direction):
    axis = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}[abs(direction)]
    return f"{node}{'-' if direction < 0 else '+'}{axis}"


def check_frf(py, uff, csv_path, tol):
    sets = [d for d in pyuff_read(py, uff) if d["type"] == 58 and d["func"] == 4]
    table = read_frf_csv(csv_path)
    worst = 0.0
    for d in sets:
        ch = dof_text(*d["rsp"]) + "/" + dof_text(*d["ref"])
        rows = table[(d["load_case"], ch)]
        assert len(rows) == len(d["x"]), (ch, len(rows), len(d["x"]))
        scale = max(abs(complex(r[1], r[2])) for r in rows)
        for (f, re, im), x, a, b in zip(rows, d["x"], d["re"], d["im"]):
            assert abs(f - x) <= 1e-9 * max(1.0, abs(f)), (ch, f, x)
            worst = max(worst, abs(complex(a, b) - complex(re, im)) / scale)
    assert worst <= tol, f"{uff}: FRF differs by {worst:.3g} of the peak"
    return len(sets), worst


def read_modes_csv(directory):
    modes = {}
    for r in csv.DictReader(open(os.path.join(directory, "modes.csv"))):
        key = (int(r.get("position") or 0), int(r["mode"]))
        modes[key] = (float(r["frequency_hz"]), float(r["damping_ratio"]), {})
    for r in csv.DictReader(open(os.path.join(directory, "mode_shapes.csv"))):
        key = (int(r.get("position") or 0), int(r["mode"]))
        modes[key][2][(int(r["node"]), r["direction"])] = complex(float(r["real"]), float(r["imag"]))
    return modes


def check_modes(py, uff, csv_dir, mass_normalized):
    import math
    sets = [d for d in pyuff_read(py, uff) if d["type"] == 55]
    table = read_modes_csv(csv_dir)
    assert len(sets) == len(table), (len(sets), len(table))
    worst_f = worst_shape = 0.0
    for d in sets:
        f, zeta, shape = table[(d["load_case"], d["mode"])]
        assert d["data_type"] in (2, 5), d["data_type"]
        if d["analysis"] == 2:
            ff, zz = d["freq"], d["zeta"]
            assert d["modal_m"] == (1.0 if mass_normalized else 0.0), d["modal_m"]
        else:
            e = complex(*d["eig"])
            ff, zz = abs(e) / (2 * math.pi), -e.real / abs(e)
            a = complex(*d["modal_a"])
            expect = complex(0, 2 * e.imag) if mass_normalized else 0
            assert abs(a - expect) <= 1e-5 * max(1.0, abs(expect)), (a, expect)
        worst_f = max(worst_f, abs(ff - f) / f, abs(zz - zeta) / max(zeta, 1e-12))
        for (node, direction), v in shape.items():
            k = d["nodes"].index(node)
            axis = {"+X": "r1", "+Y": "r2", "+Z": "r3", "-X": "r1", "-Y": "r2", "-Z": "r3"}[direction]
            got = complex(*d[axis][k]) * (-1 if direction.startswith("-") else 1)
            scale = max(abs(x) for x in shape.values())
            worst_shape = max(worst_shape, abs(got - v) / scale)
    assert worst_f <= 5e-7, f"{uff}: frequency/damping differ by {worst_f:.3g}"
    assert worst_shape <= 5e-7, f"{uff}: shapes differ by {worst_shape:.3g}"
    return len(sets), max(worst_f, worst_shape)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--venv", default=os.path.join(tempfile.gettempdir(), "modalflow-pyuff-venv"))
    args = ap.parse_args()
    py = venv_python(args.venv)
    work = tempfile.mkdtemp(prefix="pyuff_roundtrip_")
    model = os.path.join(ROOT, "pipelines", "models", "three_mass.yaml")
    pipe = os.path.join(work, "pipeline.yaml")
    with open(pipe, "w") as fh:
        fh.write(PIPELINE.format(model=model))
    subprocess.check_call(
        ["cargo", "run", "--release", "--quiet", "--", "run", pipe,
         "--cache", os.path.join(work, "cache"), "--results", os.path.join(work, "results"),
         "--progress", "none"],
        cwd=ROOT, stdout=subprocess.DEVNULL)
    res = os.path.join(work, "results", "pyuff_roundtrip")
    out = lambda stage, f: os.path.join(res, stage, "export", f)
    n, w = check_frf(py, out("uff", "frf.uff"), out("csv_truth", "frf.csv"), 1e-11)
    print(f"UFF 58 ASCII: {n} FRFs read by pyuff, largest difference {w:.2e} of the peak")
    n, w = check_frf(py, out("uffb", "frf.uff"), out("csv_noisy", "frf.csv"), 0.0)
    print(f"UFF 58b: {n} FRFs read by pyuff, largest difference {w:.2e} of the peak")
    n, w = check_modes(py, out("uff", "modes.uff"), os.path.join(res, "csv_truth", "export"), True)
    print(f"UFF 55 normal modes: {n} read by pyuff, modal mass 1, frequency/damping/shapes within {w:.1e}")
    n, w = check_modes(py, out("uffb", "modes.uff"), os.path.join(res, "csv_truth", "export"), True)
    print(f"UFF 55 (58b export): {n} read by pyuff, frequency/damping/shapes within {w:.1e}")
    n, w = check_modes(py, out("ema_uff", "modes.uff"), os.path.join(res, "ema_csv", "export"), False)
    print(f"UFF 55 complex modes (AutoEMA): {n} read by pyuff, modal A 0 (scale unknown), frequency/damping/shapes within {w:.1e}")
    print("pyuff reads every file; values equal modalflow's CSVs")


if __name__ == "__main__":
    main()
