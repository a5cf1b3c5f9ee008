"""What the two scripts of the study share: the specimen's numbers, the classical slopes, the
mid-length window, and the straight-line fit over it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fem3d import torsion_theory as theory
from fem3d.specimens.double_torsion import TABLE_4_1

RESULTS = Path(__file__).resolve().parent / "results"
SCAN = Path(__file__).resolve().parent / "scan"

#: Mid-length cracks: a + a0 within 0.25 L ... 0.75 L (20 ... 60 mm), away from the loaded end
#: and from the far end.
WINDOW = (0.25, 0.75)


def classical_slopes(E=TABLE_4_1["E"], nu=TABLE_4_1["nu"], width=TABLE_4_1["W"], thickness=TABLE_4_1["T"],
                     support=TABLE_4_1["Wm"], load_offset=0.0):
    """dC/da (1/N) of (4.1), and with Fuller's psi in both readings: ``{label: slope}``."""
    args = (E, nu, width, thickness, support, load_offset)
    return {"(4.1)": theory.compliance_slope(*args),
            "Fuller T/W": theory.compliance_slope(*args, fuller="T/W"),
            "Fuller 2T/W": theory.compliance_slope(*args, fuller="2T/W")}


def fit(a_total, C, length=TABLE_4_1["L"]):
    """Least-squares line ``C = slope (a + a0) + offset`` over the mid-length window:
    ``(slope, offset, mask)``."""
    a_total, C = np.asarray(a_total, dtype=float), np.asarray(C, dtype=float)
    mask = (a_total >= WINDOW[0] * length) & (a_total <= WINDOW[1] * length) & np.isfinite(C)
    slope, offset = np.polyfit(a_total[mask], C[mask], 1)
    return float(slope), float(offset), mask
