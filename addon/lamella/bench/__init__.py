"""Benchmarks and stored references (pure numpy + the stochastic reference; no bpy)."""
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
REFERENCE_DIR = REPO / "tests" / "references" / "brdf"  # single-scattering rough interfaces
REFERENCE_DIR_MULTIPLE = REPO / "tests" / "references" / "brdf_multiple"  # multiple-scattering interfaces
BENCH_DIR = REPO / "bench"
