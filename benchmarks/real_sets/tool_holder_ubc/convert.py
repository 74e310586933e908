"""Convert the published tool-holder driving-point FRF (text: freq [Hz], Re, Im;
receptance in m/N) into a UFF 58 ASCII file (frf.uff) with pyuff.

Layout (from ExperimentalModalAnalysis/README.md of leekunhwee/Vibration-Signal-Processing):
accelerometer at point 1, hammer at point 1 -> H11 driving point.
The measurement direction is not documented; it is written as +X (dir 1)
for both response and reference.

Run:  /tmp/aeenv/bin/python convert.py
"""
import os
import sys
import numpy as np
import pyuff

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(here))
from uff58 import frf_record  # noqa: E402

src = os.path.join(here, "Point_1_Channel_1_CH1.txt")
out = os.path.join(here, "frf.uff")

d = np.loadtxt(src)
freq = d[:, 0]
frf = d[:, 1] + 1j * d[:, 2]
assert np.allclose(np.diff(freq), 1.0) and freq[0] == 0.0 and len(freq) == 5001

if os.path.exists(out):
    os.remove(out)
ds = frf_record(
    frf, freq,
    ids=("H11 tool holder (leekunhwee/Vibration-Signal-Processing)",
         "Point_1_Channel_1_CH1.txt, receptance m/N",
         "hammer at point 1, accelerometer at point 1"),
    rsp=("TOOLHOLDER", 1, 1), ref=("TOOLHOLDER", 1, 1),
    ordinate=(8, 1, 0, "m"),  # displacement
    denominator=(13, 0, 1, "N"),  # excitation force
    ord_data_type=5)  # complex single precision
pyuff.UFF(out).write_sets([ds], mode="add")

# round-trip check
back = pyuff.UFF(out).read_sets()
back = back if isinstance(back, dict) else back[0]
err = np.max(np.abs(back["data"] - frf)) / np.max(np.abs(frf))
print("wrote", out, "n =", len(back["data"]), "max rel. error =", err)
assert err < 1e-5
