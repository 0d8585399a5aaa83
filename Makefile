# Lamella: `make demo` (main job) and `make test` set everything up by themselves on a fresh machine.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.lamella-installed

.PHONY: setup demo test test-slow bench-accuracy references luts clean

setup: $(STAMP)

$(STAMP): pyproject.toml tools/install_bpy_pth.py
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[test,blender]"
	$(PY) tools/install_bpy_pth.py
	touch $(STAMP)

demo: setup
	$(VENV)/bin/lamella demo --out out

test: setup
	$(VENV)/bin/pytest -q -n 2

test-slow: setup
	$(VENV)/bin/pytest -q -n 2 -m slow

bench-accuracy: setup
	$(VENV)/bin/lamella bench accuracy

references: setup
	$(VENV)/bin/lamella references

luts: setup
	$(VENV)/bin/lamella luts

clean:
	rm -rf $(VENV) out
