"""ergopose: markerless ergonomic risk assessment from two ceiling fisheye cameras.

Units inside the package: metres, seconds, radians. Degrees appear only at the edges
(reports, CSV files, scoring tables). World frame: floor at z = 0, z up. Camera frame:
x right, y down, z forward.
"""

import os as _os

# One BLAS thread per process, set before numpy (or scipy) loads OpenBLAS, unless the user chose
# otherwise. ergopose's numerical work is many small matrices (the body fit solves 99 x 99
# systems, one frame after the other), and its parallelism is one process per core: OpenBLAS's
# own threads spin-wait for work, and with the cores busy (the 2D stage's processes, or anything
# else) each small product then waits for a thread to be scheduled. Measured on the 2-core machine
# under load: one body-fit step's (R, 9, 86) x (86, 1089) product 82 ms with OpenBLAS's default
# threads, 0.57 ms with one; the tracking stage of a 30 s two-worker session 311 s -> 32 s.
# Spawned worker processes inherit the setting with the environment.
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
