"""GGX reflection about the mirror direction, normalised by 1 / GD (Randrianandrasana et al. 2021
Section 6.6, Eqs. 37-38): the lobe of every rough interface's reflected light."""
from __future__ import annotations

from ..models.fgd import gd
from ..models.ggx import ggx_lobe_cos
from ..models.variance import rms_alpha
from .bsdf_node import BsdfNode, blender_anisotropy
from .kind import GD_FLOOR, LobeKind, osl_frame


def _ggx_closure_cos(ops, a, wi, wo):
    return ggx_lobe_cos(ops, wi, wo, a["ax"], a["ay"], a["cos"], a["sin"])


def _gd_scale(ops, a, wi):
    """1 / GD at the lobe's RMS roughness: exact for isotropic lobes, and within a few percent of
    the numerically integrated albedo of anisotropic GGX up to 70 degrees (the projected roughness
    along wi is much worse; measured in tests/unit/test_models.py)."""
    return 1.0 / ops.max(gd(ops, wi[2], rms_alpha(ops, a["ax"], a["ay"])), GD_FLOOR)


def _ggx_args(ops, lobe, wi):
    return {"ax": lobe.alpha_x, "ay": lobe.alpha_y, "cos": ops.cos(lobe.rotation), "sin": ops.sin(lobe.rotation)}


def _osl_tangent(c: str, s: str, t: str = "Tn", b: str = "Bn") -> str:
    return t if (c, s) == ("1.0", "0.0") else f"normalize({c} * {t} + {s} * {b})"


def _osl_ggx_reflection(a: dict) -> str:
    """Cycles' single-scattering GGX reflection without Fresnel (refract = 0) on the lobe's axes:
    the frame's tangent turned by the lobe rotation about its normal."""
    n, t, b = osl_frame(a)
    return f'microfacet("ggx", {n}, {_osl_tangent(a["cos"], a["sin"], t, b)}, {a["ax"]}, {a["ay"]}, 1.0, 0)'


def _bsdf_ggx_reflection(ops, a, wi):
    """Glossy BSDF (GGX) on the lobe's axes. EEVEE ignores the anisotropy and renders the
    Roughness socket alone, alpha = sqrt(ax ay): of the isotropic stand-ins measured (arithmetic,
    geometric and RMS mean, the larger axis, the roughness projected on the view's azimuth) the
    geometric mean is the closest to the anisotropic lobes (``bench/eevee_anisotropy.md``), so one
    node group serves Cycles and EEVEE."""
    r, aniso = blender_anisotropy(ops, a["ax"], a["ay"])
    return BsdfNode("ShaderNodeBsdfAnisotropic", {"distribution": "GGX"}, {"Roughness": r, "Anisotropy": aniso},
                    {"Normal": (0.0, 0.0, 1.0), "Tangent": (a["cos"], a["sin"], 0.0)})


KIND = LobeKind("reflection", "reflected", _ggx_closure_cos, _gd_scale, _ggx_args,
                "GGX reflection about the mirror direction, GD-normalised", _osl_ggx_reflection, _bsdf_ggx_reflection)
