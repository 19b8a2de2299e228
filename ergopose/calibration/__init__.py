"""Calibrating real cameras: intrinsics, extrinsics and an accuracy check."""
