"""Convert the published tool-holder driving-point FRF (text: freq [Hz], Re, Im;
receptance in m/N) into a UFF 58 ASCII file (frf.uff) with pyuff.

Layout (from ExperimentalModalAnalysis/README.md of leekunhwee/Vibration-Signal-Processing):
accelerometer at point 1, hammer at point 1 -> H11 driving point.
The measurement direction is not documented; it is written as +X (dir 1)
for both response and reference.

Run:  /tmp/aeenv/bin/python convert.py
"""
import os
import numpy as np
import pyuff

here = os.path.dirname(os.path.abspath(__file__))
src = os.path.join(here, "Point_1_Channel_1_CH1.txt")
out = os.path.join(here, "frf.uff")

d = np.loadtxt(src)
freq = d[:, 0]
frf = d[:, 1] + 1j * d[:, 2]
assert np.allclose(np.diff(freq), 1.0) and freq[0] == 0.0 and len(freq) == 5001

if os.path.exists(out):
    os.remove(out)
ds = pyuff.prepare_58(
    binary=0,
    id1="H11 tool holder (leekunhwee/Vibration-Signal-Processing)",
    id2="Point_1_Channel_1_CH1.txt, receptance m/N",
    id3="hammer at point 1, accelerometer at point 1",
    id4="NONE",
    id5="NONE",
    func_type=4,          # frequency response function
    ver_num=1,
    load_case_id=0,
    rsp_ent_name="TOOLHOLDER",
    rsp_node=1,
    rsp_dir=1,
    ref_ent_name="TOOLHOLDER",
    ref_node=1,
    ref_dir=1,
    ord_data_type=5,      # complex single precision
    num_pts=len(freq),
    abscissa_spacing=1,   # even spacing
    abscissa_min=float(freq[0]),
    abscissa_inc=float(freq[1] - freq[0]),
    z_axis_value=0.0,
    abscissa_spec_data_type=18,   # frequency
    abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
    abscissa_axis_units_lab="Hz",
    ordinate_spec_data_type=8,    # displacement
    ordinate_len_unit_exp=1, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
    ordinate_axis_units_lab="m",
    orddenom_spec_data_type=13,   # excitation force
    orddenom_len_unit_exp=0, orddenom_force_unit_exp=1, orddenom_temp_unit_exp=0,
    orddenom_axis_units_lab="N",
    z_axis_spec_data_type=0,
    z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
    z_axis_axis_units_lab="NONE",
    data=frf,
    x=freq,
)
pyuff.UFF(out).write_sets([ds], mode="add")

# round-trip check
back = pyuff.UFF(out).read_sets()
back = back if isinstance(back, dict) else back[0]
err = np.max(np.abs(back["data"] - frf)) / np.max(np.abs(frf))
print("wrote", out, "n =", len(back["data"]), "max rel. error =", err)
assert err < 1e-5
