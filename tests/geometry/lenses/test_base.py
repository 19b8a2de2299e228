"""The lens contract (base.py), checked for every model on real and synthetic parameters:
inverse pairs over the whole domain, NaN outside it, shapes, out=, dictionaries."""

from __future__ import annotations

import math

import numpy as np
import pytest
from lens_examples import angle_between, ray_limit, rays_at

from ergopose.errors import ConfigError
from ergopose.geometry.lenses import LENS_KINDS, lens_from_dict
from ergopose.geometry.lenses.base import BLOCK_POINTS


def normalised_radius(lens, pixels):
    return np.hypot((pixels[..., 0] - lens.cx) / lens.fx, (pixels[..., 1] - lens.cy) / lens.fy)


def edge_radius(lens) -> float:
    """Normalised image radius of max_theta (inf where the model's image is unbounded)."""
    if lens.kind in ("rectilinear", "stereographic"):
        return math.inf
    if lens.kind == "eucm" and lens.alpha <= 0.5:
        # The denominator vanishes at max_theta: the image radius grows without bound.
        near = lens.project(rays_at(np.array([lens.max_theta - 1e-9]), np.array([0.3])))
        assert normalised_radius(lens, near) > 1e6
        return math.inf
    phi = np.linspace(-math.pi, math.pi, 9)
    # max_theta itself belongs to the domain (a hair less for rounding).
    edge = lens.project(rays_at(np.full(9, lens.max_theta * (1 - 1e-12)), phi))
    assert np.isfinite(edge).all()
    radius = normalised_radius(lens, edge)
    np.testing.assert_allclose(radius, radius[0], rtol=1e-9)  # radially symmetric
    return float(radius[0])


def test_rays_round_trip_up_to_max_theta(any_lens, rng):
    lens = any_lens
    n = 100_000
    theta = rng.uniform(0.0, ray_limit(lens), n)
    theta[:3] = [0.0, ray_limit(lens), 0.5 * ray_limit(lens)]
    phi = rng.uniform(-math.pi, math.pi, n)
    rays = rays_at(theta, phi)
    pixels = lens.project(rays * rng.uniform(0.01, 100.0, (n, 1)))  # any point on the ray
    assert np.isfinite(pixels).all()
    back = lens.unproject(pixels)
    np.testing.assert_allclose(np.linalg.norm(back, axis=-1), 1.0, atol=1e-12)
    assert angle_between(back, rays).max() < 1e-9
    # The theta the lens reports matches the ray's angle from the axis.
    np.testing.assert_allclose(np.arccos(np.clip(back[:, 2], -1, 1))[theta > 0.1], theta[theta > 0.1], atol=1e-9)


def test_pixels_round_trip_over_the_whole_image_circle(any_lens, rng):
    lens = any_lens
    n = 100_000
    edge = edge_radius(lens)
    if not math.isfinite(edge):
        edge = float(normalised_radius(lens, lens.project(rays_at(np.array(ray_limit(lens)), np.array(0.0)))))
    radius = edge * np.sqrt(rng.uniform(0.0, 1.0, n))
    radius[:2] = [0.0, edge * (1 - 1e-12)]
    phi = rng.uniform(-math.pi, math.pi, n)
    pixels = np.stack([lens.cx + lens.fx * radius * np.cos(phi), lens.cy + lens.fy * radius * np.sin(phi)], -1)
    rays = lens.unproject(pixels)
    assert np.isfinite(rays).all()
    np.testing.assert_allclose(np.linalg.norm(rays, axis=-1), 1.0, atol=1e-12)
    again = lens.project(rays)
    scale = max(1.0, edge)  # unbounded models: relative to the radius sampled
    assert np.abs(again - pixels).max() < 1e-6 * scale


def test_nan_outside_the_domain(any_lens, rng):
    lens = any_lens
    # Behind the centre of projection on the axis, and the centre itself: no direction.
    assert np.isnan(lens.project(np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0]]))).all()
    # NaN in, NaN out (all coordinates).
    assert np.isnan(lens.project(np.array([[np.nan, 0.0, 1.0], [0.0, np.nan, 1.0], [0.1, 0.0, np.nan]]))).all()
    assert np.isnan(lens.unproject(np.array([[np.nan, 1.0], [1.0, np.nan]]))).all()
    if lens.max_theta < math.pi - 1e-9:
        theta = rng.uniform(lens.max_theta + 1e-6, math.pi, 1000)
        theta[0] = lens.max_theta + 1e-6
        rays = rays_at(theta, rng.uniform(-math.pi, math.pi, 1000))
        assert np.isnan(lens.project(rays)).all()
    edge = edge_radius(lens)
    if math.isfinite(edge):
        radius = edge * rng.uniform(1.0 + 1e-9, 3.0, 1000)
        phi = rng.uniform(-math.pi, math.pi, 1000)
        pixels = np.stack([lens.cx + lens.fx * radius * np.cos(phi), lens.cy + lens.fy * radius * np.sin(phi)], -1)
        assert np.isnan(lens.unproject(pixels)).all()


def test_shapes_and_out(any_lens, rng):
    lens = any_lens
    theta = rng.uniform(0.0, ray_limit(lens), (3, 5, 7))
    rays = rays_at(theta, rng.uniform(-math.pi, math.pi, (3, 5, 7)))
    pixels = lens.project(rays)
    assert pixels.shape == (3, 5, 7, 2)
    assert lens.unproject(pixels).shape == (3, 5, 7, 3)
    assert lens.project(rays[0, 0, 0]).shape == (2,)
    assert lens.unproject(pixels[0, 0, 0]).shape == (3,)
    assert lens.project(np.zeros((0, 3))).shape == (0, 2)
    # Several blocks, a non-contiguous input and a caller's buffer give the same numbers.
    n = 2 * BLOCK_POINTS + 17
    many = rays_at(rng.uniform(0.0, ray_limit(lens), n), rng.uniform(-math.pi, math.pi, n))
    wide = np.zeros((n, 5))
    wide[:, 1:4] = many
    out = np.empty((n, 2))
    assert lens.project(wide[:, 1:4], out=out) is out
    np.testing.assert_array_equal(out, lens.project(many))
    np.testing.assert_array_equal(lens.project(many[5:6])[0], out[5])
    with pytest.raises(ValueError):
        lens.project(many[:, :2])


def test_dictionary_round_trip(any_lens):
    lens = any_lens
    data = lens.to_dict()
    assert data["kind"] == lens.kind and LENS_KINDS[lens.kind] is type(lens)
    assert all(isinstance(v, float) for k, v in data.items() if k != "kind")
    again = lens_from_dict(dict(data))
    assert again == lens
    with pytest.raises(ConfigError, match="fx"):
        lens_from_dict({k: v for k, v in data.items() if k != "fx"})
    with pytest.raises(ConfigError, match="foo"):
        lens_from_dict({**data, "foo": 1.0})
    with pytest.raises(ConfigError, match="kind"):
        lens_from_dict({**data, "kind": "fisheye"})
    with pytest.raises(ConfigError, match="kind"):
        lens_from_dict({k: v for k, v in data.items() if k != "kind"})
    with pytest.raises(ConfigError, match="cx"):
        lens_from_dict({**data, "cx": "320"})


def test_frozen(any_lens):
    with pytest.raises(AttributeError):
        any_lens.fx = 1.0
