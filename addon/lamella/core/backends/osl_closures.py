"""How the OSL backend prints each lobe kind (``lamella.core.lobe_kinds``): the Cycles OSL closure
call of weight 1 whose f cos the kind's ``closure_cos`` is, given the printed expressions of the
kind's arguments (``Tn``, ``Bn`` and ``Normal`` are the shader's shading frame). A new lobe kind
adds its printer here (``CLOSURES``; a test checks every kind has one)."""
from __future__ import annotations

from typing import Callable

from ..luts import REFRACT_ETA


def _osl_tangent(c: str, s: str) -> str:
    return "Tn" if (c, s) == ("1.0", "0.0") else f"normalize({c} * Tn + {s} * Bn)"

def _osl_ggx_reflection(a: dict) -> str:
    """Cycles' single-scattering GGX reflection without Fresnel (refract = 0) on the lobe's axes:
    the shading tangent turned by the lobe rotation about the normal."""
    return f'microfacet("ggx", Normal, {_osl_tangent(a["cos"], a["sin"])}, {a["ax"]}, {a["ay"]}, 1.0, 0)'

def _osl_backscatter(a: dict) -> str:
    """Cycles' GGX reflection about the view direction V (Cycles' I points toward the viewer)."""
    return f'microfacet("ggx", V, {a["alpha"]}, 1.0, 0)'

def _osl_transmission(a: dict) -> str:
    """Cycles' refracting GGX closure (refract = 1) at index REFRACT_ETA about the closure normal
    given in the local frame."""
    n = f'normalize({a["nx"]} * Tn + {a["ny"]} * Bn + {a["nz"]} * Normal)'
    return f'microfacet("ggx", {n}, {a["alpha"]}, {REFRACT_ETA!r}, 1)'

def _osl_diffuse(a: dict) -> str:
    return "diffuse(Normal)"


CLOSURES: dict[str, Callable[[dict], str]] = {
    "reflection": _osl_ggx_reflection,
    "diffuse": _osl_diffuse,
    "backscatter": _osl_backscatter,
    "transmission": _osl_transmission,
}
