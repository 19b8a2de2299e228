import numpy as np
import pytest

from ergopose.geometry.regions import DEFAULT_LIMITS_DEG, describe, region_index, region_table


def test_rings_and_limits():
    a = np.array([0.0, 29.99, 30.0, np.degrees(np.radians(30.0)), 59.9, 60.0, 95.0, np.nan])
    assert region_index(a).tolist() == [0, 0, 1, 1, 1, 2, 2, -1]
    assert region_table() == (("central", 0.0, 30.0), ("outer", 30.0, 60.0), ("edge", 60.0, 180.0))
    assert "outer 30-60 deg" in describe(DEFAULT_LIMITS_DEG)
    with pytest.raises(ValueError):
        region_index(a, (60.0, 30.0))


def test_every_stage_uses_the_one_definition():
    """Simulator, calibration check and reconstruction report by the same rings."""
    from ergopose.calibration.check import DEFAULT_RING_BOUNDS_DEG
    from ergopose.recon.settings import ReconSettings
    from ergopose.sim.scene import LENS_REGIONS_DEG

    assert tuple(DEFAULT_RING_BOUNDS_DEG) == DEFAULT_LIMITS_DEG
    assert tuple(ReconSettings().lens_region_limits_deg) == DEFAULT_LIMITS_DEG
    assert LENS_REGIONS_DEG == region_table()
