"""Write the 26 measured accelerances of dam0.unv (1 reference x 26 responses,
as measured) transposed by Maxwell-Betti reciprocity (H_jk = H_kj) into
frf_26x1.uff: 26 references (nodes 1-13 and 101-113, dir +1) x 1 response
(node 3, dir +1), the layout a roving-hammer test of the same points would
store. The numbers are dam0.unv's own, unchanged; only the node roles swap.
The ordinate stays acceleration over force (data characteristics 12/13, no
unit labels, as in dam0.unv).

Run:  /tmp/aeenv/bin/python convert.py    (README.md)
"""
import hashlib
import os
import sys

import numpy as np
import pyuff

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(here))
from uff58 import frf_record, write_checked  # noqa: E402

SHA256 = "a6804cdaba22520c23f1417073414acb85903e80f96114c6ebfcf3dfd6c5fbc7"


def main():
    src = os.path.join(here, "dam0.unv")
    assert hashlib.sha256(open(src, "rb").read()).hexdigest() == SHA256, "dam0.unv is not the stored version"
    sets = pyuff.UFF(src).read_sets()
    assert len(sets) == 26 and all(s["type"] == 58 and s["ref_node"] == 3 for s in sets)
    freq = np.asarray(sets[0]["x"])
    assert len(freq) == 401 and np.allclose(np.diff(freq), 0.03125)
    records = [frf_record(s["data"], freq,
                          ids=("dam0.unv (murmlgrmpf/uff, BSD-2-Clause), transposed by reciprocity",
                               "accelerance, no unit labels",
                               f"response node 3, reference node {s['rsp_node']}"),
                          rsp=("NONE", 3, 1), ref=("NONE", s["rsp_node"], 1),
                          ordinate=(12, 0, 0, "NONE"), denominator=(13, 0, 0, "NONE"),
                          ord_data_type=5)
               for s in sets]
    print("largest relative round-trip error:", write_checked(os.path.join(here, "frf_26x1.uff"), records))


if __name__ == "__main__":
    main()
