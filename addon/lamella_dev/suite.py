"""The accuracy suite: the paper-figure stacks every model is measured on, the incidence angles,
and the hemisphere grid of outgoing directions (docs/design.md "Metrics").

The stacks live as JSON in ``lamella/data/stacks`` (shipped: the "Paper:" presets are some of them) (``SUITE.json`` lists them with a one-line
description), so they double as examples for ``lamella lobes`` and ``lamella plot``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from lamella.core.hemisphere import wo_grid
from lamella.core.presets import DATA_DIR
from lamella.core.stack import Stack

STACK_DIR = DATA_DIR / "stacks"  # shipped: eight of them are the "Paper:" presets
# Stacks outside the accuracy suite (no stored references), e.g. the 4-coat stress stack the OSL
# exactness test and the shader-cost table use.
EXAMPLE_DIR = Path(__file__).resolve().parent / "data" / "examples"
WI_DEGREES = (0.0, 30.0, 60.0, 75.0)
# Every incidence a stored reference may hold, in the order that numbers their random seeds (an
# angle's seed offset is its position here, so adding an angle to stored references leaves the
# others' seeds as they were): 45 degrees came after the first four.
REFERENCE_ANGLES = (*WI_DEGREES, 45.0)
WI_AZIMUTH = 0.0  # incidence plane along the shading tangent
# One suite case of each family (a rough coat over a metal, anisotropy, several coats, an absorbing
# coat, thin and dense media, a diffuse base, glass, ENDF): the render tests that run per case run
# these in `make test` and every case in `make test-long` (the shaders' structure follows the
# family; the values are the numpy tests')
ONE_PER_FAMILY = ("frosted_metal", "rotated_60", "three_coats", "tinted_varnish", "fog_g09_d1", "green_scatter_d6",
                  "varnished_wood", "rough_glass_plate", "endf_thin_gold")


def descriptions() -> dict[str, str]:
    return json.loads((STACK_DIR / "SUITE.json").read_text())


def names() -> list[str]:
    return list(descriptions())


def pending_descriptions() -> dict[str, str]:
    """Cases with stored BRDF references that join the suite once their image references exist
    (``PENDING.json``)."""
    return json.loads((STACK_DIR / "PENDING.json").read_text())


def load(name: str) -> Stack:
    return Stack.from_json((STACK_DIR / f"{name}.json").read_text())


def example(name: str) -> Stack:
    return Stack.from_json((EXAMPLE_DIR / f"{name}.json").read_text())


def incident(theta_deg: float, phi: float = WI_AZIMUTH) -> np.ndarray:
    t = math.radians(theta_deg)
    return np.array([math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)])


def wo_grid_transmitted(wi: np.ndarray, n_theta: int = 16, n_phi: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """The lower-hemisphere counterpart of ``wo_grid`` for stacks on a transmissive base: the
    reflection grid mirrored through the surface, so its cells crowd around the straight-through
    direction -wi (the mean direction of light crossing a plate with the same medium on both
    sides) and its weights integrate over the lower hemisphere."""
    wo, weight = wo_grid(wi, n_theta, n_phi)
    return wo * np.array([1.0, 1.0, -1.0]), weight
