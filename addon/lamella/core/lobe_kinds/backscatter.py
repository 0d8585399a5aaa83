"""GGX reflection about the incident direction: light a scattering medium sends back toward the
viewer."""
from __future__ import annotations

from ..models.fgd import gd
from ..models.ggx import ggx_lobe_cos
from .bsdf_node import BsdfNode
from .kind import GD_FLOOR, LobeKind


def _backscatter_closure_cos(ops, a, wi, wo):
    """An isotropic GGX reflection whose normal is the incident direction: its mirror direction
    is wi itself (back-scattered light returns toward the viewer). Evaluated in that lobe's frame
    (z' = wi): only c = wo . wi matters; zero below the surface."""
    c = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]
    sin_c = ops.sqrt(ops.max(1.0 - c * c, 0.0))
    value = ggx_lobe_cos(ops, (0.0, 0.0, 1.0), (sin_c, 0.0, c), a["alpha"], a["alpha"], 1.0, 0.0)
    return ops.select(wo[2] > 0.0, value, 0.0)


def _backscatter_scale(ops, a, wi):
    """1 / GD at normal incidence in the lobe's own frame (its mean is its normal)."""
    return 1.0 / ops.max(gd(ops, 1.0, a["alpha"]), GD_FLOOR)


def _backscatter_args(ops, lobe, wi):
    return {"alpha": lobe.alpha_x}


def _osl_backscatter(a: dict) -> str:
    """Cycles' GGX reflection about the view direction V (Cycles' I points toward the viewer)."""
    return f'microfacet("ggx", V, {a["alpha"]}, 1.0, 0)'


def _bsdf_backscatter(ops, a, wi):
    """Glossy BSDF (GGX, isotropic) about the view direction."""
    return BsdfNode("ShaderNodeBsdfAnisotropic", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(a["alpha"]), "Anisotropy": 0.0},
                    {"Normal": tuple(wi), "Tangent": None})


KIND = LobeKind("backscatter", "reflected", _backscatter_closure_cos, _backscatter_scale, _backscatter_args,
                "GGX reflection about the incident direction (light back-scattered by a medium)", _osl_backscatter,
                _bsdf_backscatter)
