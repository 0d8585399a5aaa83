"""The layered models, written once over the abstract ops (no numpy import anywhere in here).

``VARIANTS`` maps each public model name to its definition; ``run_model`` traces/evaluates one on
any backend; ``eval_lobes_cos`` turns lobes into f(wi, wo) * wo.z with the GD normalisation of
paper 001 Eq. (37) so that a lobe of weight e reflects exactly e.
"""
from __future__ import annotations

from .adding_doubling import Lobe, UnsupportedStack, Variant, adding_doubling
from .fgd import gd
from .ggx import ALPHA_EVAL_MIN, ggx_lobe_cos, rotate_to_lobe
from .rgb import RGB
from .roughness import MAPPINGS
from .variance import AxisVariance, CovarianceVariance, ScalarVariance

VARIANTS = {
    "belcour2018": Variant("belcour2018", ScalarVariance, MAPPINGS["belcour"]),
    "weier2020": Variant("weier2020", AxisVariance, MAPPINGS["weier"]),
    "yamaguchi2019": Variant("yamaguchi2019", CovarianceVariance, MAPPINGS["belcour"]),
}
AUTO = "yamaguchi2019"  # the most general applicable model for the stacks supported so far


def variant(name: str, mapping: str | None = None, tir: bool | None = None) -> Variant:
    """A variant by name, optionally with another roughness<->variance mapping or TIR switch."""
    if name == "auto":
        name = AUTO
    if name not in VARIANTS:
        raise ValueError(f"unknown model {name!r}; available: {', '.join(['auto', *VARIANTS])}")
    v = VARIANTS[name]
    if mapping is not None:
        v = Variant(v.name, v.spread, MAPPINGS[mapping], v.tir)
    if tir is not None:
        v = Variant(v.name, v.spread, v.mapping, tir)
    return v


def run_model(ops, stack, wi, model: Variant) -> list[Lobe]:
    return adding_doubling(ops, stack, wi, model)


def eval_lobes_cos(ops, lobes: list[Lobe], wi, wo) -> RGB:
    """sum_k e_k rho(wi, wo; alpha_k) wo.z / GD(wi, alpha_k) (paper 001 Eqs. 37-38). A lobe's GD
    is read at the roughness its axes project to along wi (Heitz 2014 Eq. 80), which is exact
    for isotropic lobes and the usual stretch approximation for anisotropic ones."""
    total = RGB.splat(0.0)
    wx, wy, wz = wi
    sin2 = wx * wx + wy * wy
    for lobe in lobes:
        c, s = ops.cos(lobe.rotation), ops.sin(lobe.rotation)
        rho_cos = ggx_lobe_cos(ops, wi, wo, lobe.alpha_x, lobe.alpha_y, c, s)
        lx, ly = rotate_to_lobe(ops, wx, wy, c, s)
        ax = ops.max(lobe.alpha_x, ALPHA_EVAL_MIN)
        ay = ops.max(lobe.alpha_y, ALPHA_EVAL_MIN)
        a_proj = ops.sqrt((ax * ax * lx * lx + ay * ay * ly * ly) / ops.max(sin2, 1e-12))
        a_proj = ops.select(sin2 > 1e-12, a_proj, ops.sqrt(ax * ay))
        norm = rho_cos / ops.max(gd(ops, wz, a_proj), 1e-6)
        total = total + lobe.weight * norm
    return total


__all__ = ["Lobe", "UnsupportedStack", "Variant", "VARIANTS", "AUTO", "variant", "run_model",
           "eval_lobes_cos", "RGB"]
