"""Benchmarks and stored references (pure numpy + the stochastic reference; no bpy at import).

Every bench module registers its ``Bench`` (``registry``) at its bottom; the imports at the end of
this file are where the built-in benches join ``lamella bench``."""
from .page import write_page
from .paths import BENCH_DIR, REFERENCE_DIR, REFERENCE_DIR_MULTIPLE, REPO
from .registry import BENCHES, Bench, cases_argument, register, unregister

# the built-in benches (each registers itself)
from . import (  # noqa: E402
    accuracy, albedo_controls, coat_darkening, eevee_anisotropy_fit, eevee_anisotropy_images, eevee_closures, eevee_engine_switch, eevee_gap, eevee_standins,
    energy, glass_plate_paths, holdout, image_references, images, interface_variants, layer_normals, linked_tables, live_osl, lobe_floor, luts_error,
    materialx,
    node_cost, osl_cost, pareto, recompile, scene, staging,
    thin_film, trapping,
)

__all__ = ["BENCHES", "Bench", "register", "unregister", "cases_argument", "write_page", "BENCH_DIR", "REPO",
           "REFERENCE_DIR", "REFERENCE_DIR_MULTIPLE", "accuracy", "albedo_controls", "coat_darkening", "eevee_anisotropy_fit",
           "eevee_anisotropy_images",
           "eevee_closures", "eevee_engine_switch", "eevee_gap", "eevee_standins", "energy", "glass_plate_paths", "holdout",
           "image_references", "images", "interface_variants", "layer_normals", "linked_tables", "live_osl", "lobe_floor",
           "luts_error", "materialx", "node_cost", "osl_cost", "pareto", "recompile", "scene", "staging", "thin_film",
           "trapping"]
