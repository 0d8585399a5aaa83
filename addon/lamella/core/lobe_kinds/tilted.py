"""Isotropic GGX reflection about a tilted normal: what a renderer that draws every lobe round
(EEVEE) is given in place of an anisotropic lobe, a few of these with normals tilted along the
lobe's long axis (``isotropic_fit``). The closure is the Glossy BSDF with its Normal socket set to
the tilted normal n: GGX (``models.ggx.ggx_lobe_cos``, alpha_x = alpha_y) with wi and wo measured
from n, nothing where wi is below n's horizon or wo below the surface's. Staging gives each
stand-in its weight from the fit (its share of the lobe's energy times its own normaliser);
``scale`` is 1 / GD about n, for a lobe of this kind a model would emit."""
from __future__ import annotations

from ..models.fgd import gd
from ..models.ggx import ggx_lobe_cos
from .bsdf_node import BsdfNode
from .kind import GD_FLOOR, LobeKind, osl_frame


def _about_normal(ops, a, v):
    """``v`` (local-frame components) in a frame about the tilted normal n = (nx, ny, nz): the
    tangent (nz, 0, -nx) / |.| is perpendicular to n and never vanishes while nz > 0 (a stand-in
    is tilted by less than 90 degrees), the bitangent n x t."""
    nx, ny, nz = a["nx"], a["ny"], a["nz"]
    inv = 1.0 / ops.sqrt(ops.max(nz * nz + nx * nx, 1e-30))
    tx, tz = nz * inv, (0.0 - nx) * inv
    bx, by, bz = ny * tz, nz * tx - nx * tz, (0.0 - ny) * tx
    x, y, z = v
    return (x * tx + z * tz, x * bx + y * by + z * bz, x * nx + y * ny + z * nz)


def _tilted_cos(ops, a, wi, wo):
    li = _about_normal(ops, a, wi)
    f = ggx_lobe_cos(ops, li, _about_normal(ops, a, wo), a["alpha"], a["alpha"], 1.0, 0.0)
    return ops.select(wo[2] > 0.0, ops.select(li[2] > 0.0, f, 0.0), 0.0)


def _gd_scale(ops, a, wi):
    mu = wi[0] * a["nx"] + wi[1] * a["ny"] + wi[2] * a["nz"]
    return 1.0 / ops.max(gd(ops, ops.max(mu, 0.0), a["alpha"]), GD_FLOOR)


def _args(ops, lobe, wi):
    """A lobe of this kind a model would emit (none does: staging makes these closures from the fit):
    alpha sqrt(ax ay) about the shading normal, untilted."""
    return {"alpha": ops.sqrt(lobe.alpha_x * lobe.alpha_y), "nx": 0.0, "ny": 0.0, "nz": 1.0}


def _osl(a: dict) -> str:
    n, t, b = osl_frame(a)
    return (f'microfacet("ggx", normalize({a["nx"]} * {t} + {a["ny"]} * {b} + {a["nz"]} * {n}), '
            f'{a["alpha"]}, 1.0, 0)')


def _node(ops, a, wi):
    """The Glossy BSDF (GGX, no anisotropy) of roughness sqrt(alpha) with the tilted Normal."""
    return BsdfNode("ShaderNodeBsdfAnisotropic", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(ops.max(a["alpha"], 0.0)), "Anisotropy": 0.0},
                    {"Normal": (a["nx"], a["ny"], a["nz"]), "Tangent": None})


KIND = LobeKind("tilted_reflection", "reflected", _tilted_cos, _gd_scale, _args,
                "isotropic GGX reflection about a tilted normal (EEVEE's stand-in for an anisotropic lobe)",
                _osl, _node)
