"""One UFF 58 record (pyuff's `prepare_58`) for the convert scripts of the measured sets: a
function of an evenly spaced frequency axis, in ASCII.

    frf_record(data, freq, ids=(id1, id2, id3), rsp=("ENTITY", node, dir), ref=(...),
               ordinate=(spec_type, length_exp, force_exp, "label"), denominator=(...),
               func_type=4, ord_data_type=6)

`ordinate`/`denominator`: the UFF data characteristic (e.g. 8 displacement, 12 acceleration,
13 excitation force, 0 unknown), the length and force unit exponents and the unit label.
"""
import os

import numpy as np
import pyuff

UNKNOWN = (0, 0, 0, "NONE")


def frf_record(data, freq, *, ids, rsp, ref, ordinate=UNKNOWN, denominator=UNKNOWN, func_type=4,
               ord_data_type=6):
    (o_type, o_len, o_force, o_lab), (d_type, d_len, d_force, d_lab) = ordinate, denominator
    return pyuff.prepare_58(
        binary=0,
        id1=ids[0], id2=ids[1], id3=ids[2], id4="NONE", id5="NONE",
        func_type=func_type,
        ver_num=1,
        load_case_id=0,
        rsp_ent_name=rsp[0], rsp_node=rsp[1], rsp_dir=rsp[2],
        ref_ent_name=ref[0], ref_node=ref[1], ref_dir=ref[2],
        ord_data_type=ord_data_type,
        num_pts=len(data),
        abscissa_spacing=1,  # even spacing
        abscissa_min=float(freq[0]),
        abscissa_inc=float(freq[1] - freq[0]),
        z_axis_value=0.0,
        abscissa_spec_data_type=18,  # frequency
        abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=o_type,
        ordinate_len_unit_exp=o_len, ordinate_force_unit_exp=o_force, ordinate_temp_unit_exp=0,
        ordinate_axis_units_lab=o_lab,
        orddenom_spec_data_type=d_type,
        orddenom_len_unit_exp=d_len, orddenom_force_unit_exp=d_force, orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab=d_lab,
        z_axis_spec_data_type=0,
        z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
        z_axis_axis_units_lab="NONE",
        data=data,
        x=freq,
    )


def write_checked(path, sets):
    """Write the 58 records `sets` to `path` (replacing it) and read them back with pyuff:
    the largest error relative to each record's peak must stay below 1e-5 (single precision
    ASCII). Returns that error."""
    if os.path.exists(path):
        os.remove(path)
    pyuff.UFF(path).write_sets(sets, mode="add")
    back = pyuff.UFF(path).read_sets()
    back = [back] if isinstance(back, dict) else back
    err = max(np.max(np.abs(b["data"] - s["data"])) / np.max(np.abs(s["data"]))
              for b, s in zip(back, sets))
    print("wrote", path, len(back), "FRFs of", len(back[0]["data"]), "lines, max rel. error", err)
    assert len(back) == len(sets) and err < 1e-5, path
    return err
