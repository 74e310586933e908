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

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(here))
from uff58 import frf_record, write_checked  # noqa: E402

src = os.path.join(here, "Point_1_Channel_1_CH1.txt")
out = os.path.join(here, "frf.uff")

d = np.loadtxt(src)
freq = d[:, 0]
frf = d[:, 1] + 1j * d[:, 2]
assert np.allclose(np.diff(freq), 1.0) and freq[0] == 0.0 and len(freq) == 5001

write_checked(out, [frf_record(
    frf, freq,
    ids=("H11 tool holder (leekunhwee/Vibration-Signal-Processing)",
         "Point_1_Channel_1_CH1.txt, receptance m/N",
         "hammer at point 1, accelerometer at point 1"),
    rsp=("TOOLHOLDER", 1, 1), ref=("TOOLHOLDER", 1, 1),
    ordinate=(8, 1, 0, "m"),  # displacement
    denominator=(13, 0, 1, "N"),  # excitation force
    ord_data_type=5)])  # complex single precision

# The roving-hammer test, when the four other published files are beside this one
# (Point_k_Channel_1_CH1.txt: hammer at point k, accelerometer at the tool tip,
# point 1; README "Files"): as measured, 5 references x 1 response
# (frf_roving_5x1.uff), and the same numbers transposed by Maxwell-Betti
# reciprocity, 1 reference x 5 responses (frf_roving_1x5.uff).
points = [os.path.join(here, f"Point_{k}_Channel_1_CH1.txt") for k in range(1, 6)]
if all(os.path.exists(p) for p in points):
    columns = []
    for p in points:
        d = np.loadtxt(p)
        assert np.array_equal(d[:, 0], freq), p
        columns.append(d[:, 1] + 1j * d[:, 2])
    for name, pairs in [("frf_roving_5x1.uff", [(1, k) for k in range(1, 6)]),
                        ("frf_roving_1x5.uff", [(k, 1) for k in range(1, 6)])]:
        write_checked(os.path.join(here, name), [frf_record(
            h, freq,
            ids=("Tool holder roving-hammer test (leekunhwee/Vibration-Signal-Processing)",
                 f"Point_{k}_Channel_1_CH1.txt, receptance m/N",
                 f"response node {rsp}, reference node {ref}"),
            rsp=("TOOLHOLDER", rsp, 1), ref=("TOOLHOLDER", ref, 1),
            ordinate=(8, 1, 0, "m"), denominator=(13, 0, 1, "N"), ord_data_type=5)
            for k, (h, (rsp, ref)) in enumerate(zip(columns, pairs), start=1)])
