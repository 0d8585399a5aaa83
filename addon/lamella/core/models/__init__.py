"""The layered models, written once over the abstract ops (no numpy import anywhere in here).

``VARIANTS`` maps each public model name to its definition; ``run_model`` traces/evaluates one on
any backend; ``eval_lobes_cos`` turns lobes into f(wi, wo) * wo.z with the GD normalisation of
paper 001 Eq. (37) so that a lobe of weight e reflects exactly e.
"""
from __future__ import annotations

from .adding_doubling import Lobe, UnsupportedStack, Variant, adding_doubling
from .fgd import gd
from .ggx import ggx_lobe_cos
from .rgb import RGB
from .roughness import MAPPINGS
from .variance import AxisVariance, CovarianceVariance, ScalarVariance, rms_alpha

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
    """sum_k e_k rho(wi, wo; alpha_k) wo.z / GD(wi, alpha_k) (paper 001 Eqs. 37-38). GD is read
    at the lobe's RMS roughness: exact for isotropic lobes, and within a few percent of the
    numerically integrated albedo of anisotropic GGX up to 70 degrees (the projected roughness
    along wi is much worse; measured in tests/unit/test_models.py)."""
    total = RGB.splat(0.0)
    wz = wi[2]
    for lobe in lobes:
        c, s = ops.cos(lobe.rotation), ops.sin(lobe.rotation)
        rho_cos = ggx_lobe_cos(ops, wi, wo, lobe.alpha_x, lobe.alpha_y, c, s)
        a_rms = rms_alpha(ops, lobe.alpha_x, lobe.alpha_y)
        norm = rho_cos / ops.max(gd(ops, wz, a_rms), 1e-6)
        total = total + lobe.weight * norm
    return total


__all__ = ["Lobe", "UnsupportedStack", "Variant", "VARIANTS", "AUTO", "variant", "run_model",
           "eval_lobes_cos", "RGB"]
