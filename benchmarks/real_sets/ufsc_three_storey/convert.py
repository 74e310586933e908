"""Convert the three measured accelerances of a three-storey building model
(FRF.csv: a "Spectrum2DComplex" CSV export, semicolons, decimal commas) into
UFF 58 ASCII files with pyuff, in both layouts:

- frf_1x3.uff: as measured, 1 reference (the force, Signal 1; where it acted
  is not documented, written as node 100) x 3 responses (Signal 2, 3, 4 =
  floors 1, 2, 3 by the authors' plots: nodes 1, 2, 3);
- frf_3x1.uff: the same numbers transposed by Maxwell-Betti reciprocity
  (H_jk = H_kj): 3 references (nodes 1, 2, 3) x 1 response (node 100), the
  layout of a roving-hammer test.

Directions are not documented; all are written as +X (dir 1).

Run:  /tmp/aeenv/bin/python convert.py    (FRF.csv fetched beside it; README.md)
"""
import hashlib
import os
import sys

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(here))
from uff58 import frf_record, write_checked  # noqa: E402

src = os.path.join(here, "FRF.csv")
SHA256 = "098411a7916e8d81aa43796c55980a04fdb2024cbaaafe05b45f1f71ed5806c4"

raw = open(src, "rb").read()
assert hashlib.sha256(raw).hexdigest() == SHA256, "FRF.csv is not the stored version (README.md)"
rows = [l for l in raw.decode("utf-8").splitlines() if l[:1].isdigit()]
d = np.array([[float(v.replace(",", ".")) for v in l.split(";")] for l in rows])
freq = d[:, 0]
frf = d[:, 1::2] + 1j * d[:, 2::2]  # lines x 3 channels
assert frf.shape == (801, 3) and np.allclose(np.diff(freq), 0.5) and freq[0] == 0.0


def record(data, rsp_node, ref_node):
    return frf_record(
        data, freq,
        ids=("Three-storey building model, UFSC (Daniel-Sottovia/Grupo-6)",
             "FRF.csv, H1 accelerance (m/s^2)/N",
             f"response node {rsp_node}, reference node {ref_node}"),
        rsp=("BUILDING", rsp_node, 1), ref=("BUILDING", ref_node, 1),
        ordinate=(12, 1, 0, "m/s^2"),  # acceleration
        denominator=(13, 0, 1, "N"),  # excitation force
        ord_data_type=5)


for name, pairs in [("frf_1x3.uff", [(c + 1, 100) for c in range(3)]),
                    ("frf_3x1.uff", [(100, c + 1) for c in range(3)])]:
    write_checked(os.path.join(here, name),
                  [record(frf[:, c], rsp, ref) for c, (rsp, ref) in enumerate(pairs)])
