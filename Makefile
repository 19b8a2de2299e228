# ergopose: make test | make demo | make bench
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.deps-installed

.PHONY: test demo bench install clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# Third-party dependencies: reinstalled only when pyproject.toml or constraints.txt change.
$(STAMP): pyproject.toml constraints.txt | $(PY)
	$(PY) -m pip install -q "setuptools>=68" wheel
	$(PY) -m pip install -q -c constraints.txt ".[test]"
	touch $(STAMP)

# The package itself (not editable, so the installed copy carries assessments/ and templates/).
install: $(STAMP)
	$(PY) -m pip install -q --no-deps --force-reinstall --no-build-isolation .

test: install
	$(PY) -m pytest -q

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
