"""Evaluation of an assessed simulated session against its ground truth (``ergopose evaluate``).

docs/evaluation.md defines every figure. Simulated sessions only: the ground truth comes from
``ergopose simulate`` (ergopose.sim.ground_truth). :mod:`ergopose.evaluation.pose` measures the
2D stage alone on a simulated session (docs/pose-in-fisheye.md). Nothing in the product imports
this package (docs/architecture.md).
"""
