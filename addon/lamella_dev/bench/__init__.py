"""Benchmarks and stored references (pure numpy + the stochastic reference; no bpy at import).

Every bench module registers its ``Bench`` (``registry``) at its bottom; the imports at the end of
this file are where the built-in benches join ``lamella bench``."""
from pathlib import Path


def _repository() -> Path:
    """The checkout this package runs from (where the stored references and bench/ live), or the
    working folder for an installed copy, so that a benchmark never writes into site-packages."""
    here = Path(__file__).resolve().parents[3]
    return here if (here / "pyproject.toml").is_file() and (here / "tests").is_dir() else Path.cwd()


REPO = _repository()
REFERENCE_DIR = REPO / "tests" / "references" / "brdf"  # single-scattering rough interfaces
REFERENCE_DIR_MULTIPLE = REPO / "tests" / "references" / "brdf_multiple"  # multiple-scattering interfaces
BENCH_DIR = REPO / "bench"

from .page import write_page  # noqa: E402
from .registry import BENCHES, Bench, cases_argument, register, unregister  # noqa: E402

# the built-in benches (each registers itself; after the paths above, which they import)
from . import (  # noqa: E402,F401
    accuracy, albedo_controls, eevee_closures, eevee_gap, eevee_standins, energy, holdout, image_references, images,
    linked_tables, lobe_floor, luts_error, materialx, node_cost, osl_cost, pareto, recompile, scene, staging,
    trapping,
)
