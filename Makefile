# ergopose: make test | make test-fast | make check | make demo | make bench | make settings-docs
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.deps-installed

.PHONY: test test-fast check demo bench install clean settings-docs

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# Third-party dependencies: reinstalled only when pyproject.toml or constraints.txt change.
$(STAMP): pyproject.toml constraints.txt | $(PY)
	$(PY) -m pip install -q "setuptools>=68" wheel
	$(PY) -m pip install -q -c constraints.txt ".[test,cluster]"
	touch $(STAMP)

# The package itself (not editable, so the installed copy carries assessments/ and templates/).
install: $(STAMP)
	$(PY) -m pip install -q --no-deps --force-reinstall --no-build-isolation .

# Lint and format check (ruff; `ruff format ergopose tests bench conftest.py` formats) and type
# check (mypy --strict on the product, sim/ and evaluation/ relaxed: pyproject.toml); tests/test_layers.py holds the import layers and runs
# with the tests.
check: $(STAMP)
	$(PY) -m ruff check ergopose tests bench conftest.py
	$(PY) -m ruff format --check ergopose tests bench conftest.py
	$(PY) -m mypy

# The whole suite on every core up to 4 (pytest-xdist; a test file stays in one process, so the
# fixtures a file shares are made once). On a fresh clone on this 2-core machine (2026-11-29):
# 10 min 41 s for about 22 minutes of CPU; the photo test's two models are two files
# (tests/pose/test_photos.py, test_photos_heavy.py) so that the two processes share them.
test: check install
	$(PY) -m pytest -q -n auto --maxprocesses 4 --dist loadfile

# The edit-run loop: everything but the tests marked slow, browser or network: 1,045 of the 1,354
# tests (the rest -- over about 1 s, or simulating, assessing or running the networks -- are marked
# slow; make test still runs them all). Measured on a fresh clone on this 2-core machine
# (2026-11-29): 43 s wall, with PYTHONDONTWRITEBYTECODE set (part of it goes to compiling the
# modules and rewriting the tests' asserts again, which __pycache__ saves).
test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow and not browser and not network"

# docs/settings.md from the settings model (ergopose/settings/); a test fails while it is stale.
settings-docs: $(STAMP)
	$(PY) -m ergopose.settings

demo: install
	$(PY) -m ergopose demo

# aniposelib (the reference in two benchmarks) is installed without its declared dependencies:
# they include opencv-contrib-python, which resolves to OpenCV 5 and would replace our 4.x.
bench: install
	$(PY) -m pip install -q -c constraints.txt -r bench/requirements.txt
	$(PY) -m pip install -q --no-deps -c constraints.txt aniposelib
	$(PY) bench/run.py

clean:
	rm -rf $(VENV) build *.egg-info
