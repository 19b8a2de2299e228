"""ergopose: markerless ergonomic risk assessment from two ceiling fisheye cameras.

Units inside the package: metres, seconds, radians. Degrees appear only at the edges
(reports, CSV files, scoring tables). World frame: floor at z = 0, z up. Camera frame:
x right, y down, z forward.
"""

__version__ = "0.1.0"
