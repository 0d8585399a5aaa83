"""Benchmarks and stored references (pure numpy + the stochastic reference; no bpy)."""
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
REFERENCE_DIR = REPO / "tests" / "references" / "brdf"
BENCH_DIR = REPO / "bench"
