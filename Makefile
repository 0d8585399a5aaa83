# Lamella: `make demo` (main job) and `make test` set everything up by themselves on a fresh machine.
# The main target is Blender 5.2 LTS (the bpy 5.2.3 wheel, Python 3.13: pyenv's 3.13 where pyenv
# is installed); `make test-blender-versions` runs the extension's tests on 4.2, 4.5 and 5.0
# (Python 3.11).
PYTHON ?= $(shell PYENV_VERSION=3.13.0 pyenv which python3.13 2>/dev/null || command -v python3.13)
PYTHON311 ?= $(shell PYENV_VERSION=3.11.7 pyenv which python3.11 2>/dev/null || command -v python3.11)
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.lamella-installed

.PHONY: setup demo test test-long package exports test-blender-versions bench-accuracy bench-holdout bench-images bench-recompile bench-nodes references references-multiple references-pending image-references luts clean

setup: $(STAMP)

$(STAMP): pyproject.toml tools/install_bpy_pth.py
	@test -n "$(PYTHON)" || { echo "Python 3.13 is needed (Blender 5.2's): set PYTHON=/path/to/python3.13"; exit 1; }
	@$(PYTHON) -c "import sys; assert sys.version_info[:2] == (3, 13), sys.version"
	@# a venv of another Python (the project's earlier 3.11 one) is replaced, not mixed into
	@test ! -x $(PY) || $(PY) -c "import sys; sys.exit(sys.version_info[:2] != (3, 13))" || rm -rf $(VENV)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[test,blender]"
	$(PY) tools/install_bpy_pth.py
	touch $(STAMP)

# The main job: the demo stacks' renders and contact sheet, then the showcase scene built with the
# extension (demo_blend/showcase.blend) rendered small; DEMO_FLAGS=--full renders it at 1920 x 1080.
demo: setup
	$(VENV)/bin/lamella demo --out out
	$(PY) demo_blend/build_showcase.py --out out $(DEMO_FLAGS)

test: setup
	$(VENV)/bin/pytest -q -n 2 --dist loadgroup

# The long checks `make test` leaves out (marked slow: the benches run end to end).
test-long: setup
	$(VENV)/bin/pytest -q -n 2 --dist loadgroup -m slow

# The extension zip, built and validated by Blender's own extension tool (in the bpy wheel).
package: setup
	$(PY) tools/build_extension.py dist

# The repository's generated folders, from the built-in presets (lamella export-presets): osl/ (every
# preset's OSL bundle, both view targets) and node_groups/ (every preset's node group, an asset library
# that renders without the extension), whose .blend is saved by the oldest supported Blender so every
# later one opens it: that bpy gets its venv as in test-blender-versions. The tests of
# tests/unit/test_preset_exports.py fail until this ran after a preset or the compiler changed.
OLDEST_BLENDER := 4.2.23
exports: setup
	@venv=.venv-bpy-$(OLDEST_BLENDER); \
	test -x $$venv/bin/python || $(PYTHON311) -m venv $$venv || exit 1; \
	$$venv/bin/python -c "import bpy" 2>/dev/null || { $$venv/bin/python -m pip install -q -e ".[test]" "bpy==$(OLDEST_BLENDER)" \
		&& $$venv/bin/python tools/install_bpy_pth.py; } || exit 1
	$(VENV)/bin/lamella export-presets --blender-python .venv-bpy-$(OLDEST_BLENDER)/bin/python

# The extension's tests on the other Blender releases whose bpy wheels install here (Python 3.11,
# numpy 1.x as those Blenders bundle): one venv each (.venv-bpy-<version>), the project installed
# into it with that bpy.
BLENDER_VERSIONS ?= 4.2.23 4.5.15 5.0.1
ADDON_TESTS := tests/blender/test_addon_api.py tests/blender/test_addon_operators.py tests/blender/test_addon_ui.py \
	tests/blender/test_addon_persistence.py tests/blender/test_addon_presets.py tests/blender/test_extension_package.py \
	tests/blender/test_batch.py tests/blender/test_addon_nodes.py tests/blender/test_osl_tables.py \
	tests/blender/test_stack_format_on_materials.py tests/blender/test_asset_library.py \
	tests/blender/test_extension_contract.py tests/blender/test_face.py tests/blender/test_eevee_glass.py \
	tests/blender/test_eevee_anisotropy.py \
	tests/blender/test_addon_imports.py tests/blender/test_preset_exports.py
test-blender-versions:
	@for v in $(BLENDER_VERSIONS); do \
		echo "== bpy $$v"; \
		venv=.venv-bpy-$$v; \
		test -x $$venv/bin/python || $(PYTHON311) -m venv $$venv || exit 1; \
		$$venv/bin/python -m pip install -q -e ".[test]" "bpy==$$v" || exit 1; \
		$$venv/bin/python tools/install_bpy_pth.py || exit 1; \
		$$venv/bin/python -m pytest -q -n 2 --dist loadgroup -p no:cacheprovider $(ADDON_TESTS) || exit 1; \
	done

bench-accuracy: setup
	$(VENV)/bin/lamella bench accuracy

bench-holdout: setup
	$(VENV)/bin/lamella bench holdout

# The stored BRDF references (about 50 min on 2 cores for the interface cases, 4-12 min more per
# medium case on one core): cases with a narrow exit interface need more walkers to keep the noise
# floor of bench/accuracy.md below 0.1. 45 degrees is added to the stored files afterwards, with the
# same walkers per case (suite.REFERENCE_ANGLES).
MEDIA_REST := fog_g09_d1,fog_g09_d4,fog_g0,fog_g03,fog_g07,fog_g05_d4,milky_coat_d01,milky_coat_d2,green_scatter_d1,green_scatter_d6
MEDIA_CASES := fog_g09_d01,$(MEDIA_REST)
NEW_INTERFACE_CASES := absorbing_rough_coat,varnished_wood,rough_glass_plate,thin_coat_rough_base,endf_thin_gold,endf_absorbing_gold,endf_rough_over_mirror_gold
NEW_CASES_32K := absorbing_rough_coat,varnished_wood,endf_absorbing_gold,endf_rough_over_mirror_gold
references: setup
	$(VENV)/bin/lamella references --cases frosted_metal,three_coats,rough_coat_over_mirror --spp 8192
	$(VENV)/bin/lamella references --cases gold_coated,coat_over_brushed,rotated_30,rotated_60,rotated_90,tinted_varnish,opposing_anisotropy --spp 32768
	$(VENV)/bin/lamella references --cases $(MEDIA_CASES),$(NEW_CASES_32K) --spp 32768
	$(VENV)/bin/lamella references --cases thin_coat_rough_base,rough_glass_plate --spp 65536
	$(VENV)/bin/lamella references --cases endf_thin_gold --spp 131072
	$(VENV)/bin/lamella references --wi 45 --cases frosted_metal,three_coats,rough_coat_over_mirror --spp 8192
	$(VENV)/bin/lamella references --wi 45 --cases gold_coated,coat_over_brushed,rotated_30,rotated_60,rotated_90,tinted_varnish,opposing_anisotropy --spp 32768
	$(VENV)/bin/lamella references --wi 45 --cases $(MEDIA_CASES),$(NEW_CASES_32K) --spp 32768
	$(VENV)/bin/lamella references --wi 45 --cases thin_coat_rough_base,rough_glass_plate --spp 65536
	$(VENV)/bin/lamella references --wi 45 --cases endf_thin_gold --spp 131072

# The energy-conserving BRDF references (tests/references/brdf_multiple: rough interfaces scatter on
# their microsurface until light leaves, Heitz et al. 2016), 2-5 min per case at 8192 walkers on one
# core, four times that at 32768: the cases whose narrow exit interface makes the estimate noisiest
# get the latter (their noise on the metric at 0 deg was 0.11-0.31 at 8192 walkers). 45 degrees is
# added to the stored files afterwards (suite.REFERENCE_ANGLES), as for the single-scattering set.
MULTIPLE_32K := endf_thin_gold,thin_coat_rough_base,rough_glass_plate,varnished_wood,tinted_varnish,rotated_30,opposing_anisotropy,rotated_60,green_scatter_d6,endf_absorbing_gold
MULTIPLE_8K := $(shell $(PYTHON) -c "import json; s = set('$(MULTIPLE_32K)'.split(',')); print(','.join(c for c in json.load(open('addon/lamella/data/stacks/SUITE.json')) if c not in s))")
references-multiple: setup
	$(VENV)/bin/lamella references --interfaces multiple --spp 8192 --cases $(MULTIPLE_8K)
	$(VENV)/bin/lamella references --interfaces multiple --spp 32768 --cases $(MULTIPLE_32K)
	$(VENV)/bin/lamella references --interfaces multiple --wi 45 --spp 8192 --cases $(MULTIPLE_8K)
	$(VENV)/bin/lamella references --interfaces multiple --wi 45 --spp 32768 --cases $(MULTIPLE_32K)

# BRDF references of the cases awaiting image references (PENDING.json: media, diffuse and glass
# bases, ENDF-sized coats), 4-12 min each on one core; run two halves in parallel on 2 cores.
PENDING := $(shell $(PYTHON) -c "import json; print(','.join(json.load(open('addon/lamella/data/stacks/PENDING.json'))))")
references-pending: setup
	@if [ -n "$(PENDING)" ]; then \
		$(VENV)/bin/lamella references --cases $(PENDING) --spp 32768 --out tests/references/brdf_pending; \
	else echo "no case awaits its image references (PENDING.json is empty)"; fi

# The stored image references (tests/references/images): every suite stack as nested spheres, path
# traced at 128 px; the interface cases at 2048 spp per pass (about 40 min on 2 cores), refined by a
# second pass; the media cases at 1024 spp (256 bounces: 2-7 min each), the newer interface cases
# at 1024 refined once. `make bench-images` then re-measures bench/images.md against them.
image-references: setup
	$(VENV)/bin/lamella image-references --spp 2048 --cases frosted_metal,gold_coated,coat_over_brushed,rotated_30,rotated_60,rotated_90,three_coats,tinted_varnish,rough_coat_over_mirror,opposing_anisotropy
	$(VENV)/bin/lamella image-references --spp 2048 --add --cases frosted_metal,gold_coated,coat_over_brushed,rotated_30,rotated_60,rotated_90,three_coats,tinted_varnish,rough_coat_over_mirror,opposing_anisotropy
	$(VENV)/bin/lamella image-references --spp 2048 --cases fog_g09_d01
	$(VENV)/bin/lamella image-references --spp 1024 --cases $(MEDIA_REST),$(NEW_INTERFACE_CASES)
	$(VENV)/bin/lamella image-references --spp 1024 --add --cases $(NEW_INTERFACE_CASES)

bench-images: setup
	$(VENV)/bin/lamella bench images
	$(VENV)/bin/lamella bench osl-cost

bench-recompile: setup
	$(VENV)/bin/lamella bench recompile

bench-nodes: setup
	$(VENV)/bin/lamella bench nodes
	$(VENV)/bin/lamella bench eevee-anisotropy
	$(VENV)/bin/lamella bench eevee-closures

luts: setup
	$(VENV)/bin/lamella luts

clean:
	rm -rf $(VENV) .venv-bpy-* out dist
