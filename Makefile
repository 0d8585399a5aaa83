# Lamella: `make demo` (main job) and `make test` set everything up by themselves on a fresh machine.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.lamella-installed

.PHONY: setup demo test bench-accuracy bench-images references references-pending image-references luts clean

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

bench-accuracy: setup
	$(VENV)/bin/lamella bench accuracy

# The stored BRDF references (about 50 min on 2 cores): cases with a narrow exit interface need
# more walkers to keep the noise floor of bench/accuracy.md below 0.1.
references: setup
	$(VENV)/bin/lamella references --cases frosted_metal,three_coats,rough_coat_over_mirror --spp 8192
	$(VENV)/bin/lamella references --cases gold_coated,coat_over_brushed,rotated_30,rotated_60,rotated_90,tinted_varnish,opposing_anisotropy --spp 32768

# BRDF references of the cases awaiting image references (PENDING.json: media, diffuse and glass
# bases, ENDF-sized coats), 4-12 min each on one core; run two halves in parallel on 2 cores.
PENDING := $(shell $(PYTHON) -c "import json; print(','.join(json.load(open('addon/lamella/data/stacks/PENDING.json'))))")
references-pending: setup
	$(VENV)/bin/lamella references --cases $(PENDING) --spp 32768 --out tests/references/brdf_pending

# The stored image references (tests/references/images): every suite stack as nested interface
# spheres, path traced at 128 px; 2048 spp per pass (about 40 min on 2 cores), refined by a
# second pass. `make bench-images` then re-measures bench/images.md against them.
image-references: setup
	$(VENV)/bin/lamella image-references --spp 2048
	$(VENV)/bin/lamella image-references --spp 2048 --add

bench-images: setup
	$(VENV)/bin/lamella bench images
	$(VENV)/bin/lamella bench osl-cost

luts: setup
	$(VENV)/bin/lamella luts

clean:
	rm -rf $(VENV) out
