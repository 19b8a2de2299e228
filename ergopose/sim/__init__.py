"""The simulated workplace: a scene, scripted workers, rendered fisheye videos and ground truth.

- :mod:`ergopose.sim.scene`: the rig (two ceiling fisheye cameras), furniture, reference bars,
  work stations.
- :mod:`ergopose.sim.motion`: workers of different body sizes following a scripted shift.
- :mod:`ergopose.sim.render`: z-buffered mannequins through the real lens model.
- :mod:`ergopose.sim.writer`: a complete session folder with ground truth (``ergopose simulate``).
- :mod:`ergopose.sim.ground_truth`: reading the ground truth back.
- :mod:`ergopose.sim.oracle`: an ORACLE 2D source (ground truth plus noise) for evaluation only.
- :mod:`ergopose.sim.synthetic`: scripted workers and their 2D observations without rendering, for
  tests, benchmarks and the reconstruction's measurements.

Nothing in the product imports this package (docs/architecture.md).
"""
