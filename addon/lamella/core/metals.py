"""Conductor colours for artists: measured metals and the reflectivity / edge-tint mapping.

``MEASURED``: RGB complex indices of published measurements, read from ``data/metals.json`` (each
entry cites its source and the file says how the RGB values were taken from the spectra).

``artistic_to_complex`` / ``complex_to_artistic``: Gulbrandsen 2014 ("Artist Friendly Metallic
Fresnel", JCGT 3(4), Section 3): a metal is described by its normal-incidence reflectivity r and
an edge tint g; the index n runs from n_max = (1 + sqrt r) / (1 - sqrt r) (g = 0) to
n_min = (1 - r) / (1 + r) (g = 1), and k is the extinction that gives reflectivity r at that n.
The stack always stores eta/k; these are how a user interface reads and writes them.
"""
from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path

METALS_FILE = Path(__file__).resolve().parent.parent / "data" / "metals.json"
R_MAX = 0.999  # reflectivity is clamped below 1 (n_max and k diverge at r = 1)


@lru_cache(maxsize=1)
def _load() -> dict:
    return json.loads(METALS_FILE.read_text())


def measured() -> dict[str, dict]:
    """id -> {"label", "eta": [r, g, b], "k": [r, g, b], "source"}, in the file's order."""
    return dict(_load()["metals"])


def citation(metal: dict) -> str:
    """The published measurement a metal's values come from, as one line."""
    src = metal["source"]
    return src["citation"] if isinstance(src, dict) else str(src)


def method() -> str:
    return _load()["method"]


def normal_reflectance(eta: float, k: float) -> float:
    """Fresnel reflectance of a conductor at normal incidence from vacuum."""
    return ((eta - 1.0) ** 2 + k * k) / ((eta + 1.0) ** 2 + k * k)


def artistic_to_complex(reflectivity, edge_tint) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(eta, k) RGB triples from reflectivity and edge tint RGB triples in [0, 1]
    (Gulbrandsen 2014, Section 3)."""
    etas, ks = [], []
    for r, g in zip(reflectivity, edge_tint):
        r = min(max(float(r), 0.0), R_MAX)
        g = min(max(float(g), 0.0), 1.0)
        sr = math.sqrt(r)
        n = g * (1.0 - r) / (1.0 + r) + (1.0 - g) * (1.0 + sr) / (1.0 - sr)
        k2 = (r * (n + 1.0) ** 2 - (n - 1.0) ** 2) / (1.0 - r)
        etas.append(n)
        ks.append(math.sqrt(max(k2, 0.0)))
    return tuple(etas), tuple(ks)


def complex_to_artistic(eta, k) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The inverse mapping: (reflectivity, edge tint) RGB triples of a conductor's eta/k. A
    measured metal whose n lies outside [n_min, n_max] of its reflectivity gets the nearest tint
    (the mapping then does not reproduce it exactly)."""
    refl, tint = [], []
    for n, kk in zip(eta, k):
        r = min(normal_reflectance(float(n), float(kk)), R_MAX)
        sr = math.sqrt(r)
        n_min, n_max = (1.0 - r) / (1.0 + r), (1.0 + sr) / (1.0 - sr)
        g = (n_max - n) / (n_max - n_min) if n_max > n_min else 0.0
        refl.append(r)
        tint.append(min(max(g, 0.0), 1.0))
    return tuple(refl), tuple(tint)


__all__ = ["measured", "method", "citation", "normal_reflectance", "artistic_to_complex", "complex_to_artistic", "METALS_FILE"]
