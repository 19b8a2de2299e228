"""3D reconstruction over a shift: cross-camera association, triangulation with outlier
rejection, identity tracking, Kalman smoothing, limb-length diagnostics and the tracks table.

See docs/reconstruction.md for the definitions, settings and measurements.
"""
