"""Fixtures for the lens tests; the example lenses live in lens_examples.py."""

from __future__ import annotations

import pytest
from lens_examples import EXAMPLES, make_lens


@pytest.fixture(params=EXAMPLES)
def any_lens(request, shared_data):
    return make_lens(request.param, shared_data)
