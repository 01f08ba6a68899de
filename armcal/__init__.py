"""armcal: kinematic calibration of industrial robot arms.

The method follows Stone's S-Model dissertation and Goswami, Quaid & Peshkin's
ball-bar paper (see docs/); internal units are millimetres and radians.
"""

import os

# Calibration problems are small dense matrices (hundreds to thousands of rows, tens of columns):
# a multi-threaded BLAS spends more on waking threads than on the arithmetic (pivoted QR of
# 816 x 80 here: 2.3 ms on one thread, 6.3 ms on two); armcal shares its work out itself
# (identify/threads.py: a problem's chunks, a QR's row blocks) and parallel runs use processes.
# Takes effect when armcal is imported before numpy, as the CLI does; the user's setting wins.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

__version__ = "0.1.0"
