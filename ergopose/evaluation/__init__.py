"""Evaluation of an assessed simulated session against its ground truth (``ergopose evaluate``).

docs/evaluation.md defines every figure. Simulated sessions only: the ground truth comes from
``ergopose simulate`` (ergopose.sim.ground_truth).
"""
