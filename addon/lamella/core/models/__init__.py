"""The layered models, written once over the abstract ops (no numpy import anywhere in here).

``MODELS`` is the registry of model families by public name; each entry has ``name`` and
``run(ops, stack, wi) -> list[Lobe]`` and traces/evaluates on any backend. ``auto`` resolves to a
registered model by the stack's structure alone (``choose_auto``). Lobes are evaluated through
the lobe-kind table (``lamella.core.lobe_kinds``).
"""
from __future__ import annotations

from .adding_doubling import Lobe, UnsupportedStack, Variant
from .endf import ENDF
from .rgb import RGB
from .transfer_matrix import TransferMatrix
from .roughness import MAPPINGS
from .variance import AxisVariance, CovarianceVariance, ScalarVariance

MODELS: dict = {
    "belcour2018": Variant("belcour2018", ScalarVariance, MAPPINGS["belcour"]),
    "weier2020": Variant("weier2020", AxisVariance, MAPPINGS["weier"]),
    "yamaguchi2019": Variant("yamaguchi2019", CovarianceVariance, MAPPINGS["belcour"]),
    "tm2": TransferMatrix("tm2", six_flux=False),
    "tm6": TransferMatrix("tm6", six_flux=True),
    "endf": ENDF(),
}
VARIANTS = {k: v for k, v in MODELS.items() if isinstance(v, Variant)}  # the adding-doubling family


def choose_auto(stack) -> str:
    """The model ``auto`` runs for ``stack``: a pure function of the stack's structure, so a
    shader traced with ``auto`` is static code. Decision table (measured in bench/accuracy.md):

    ====================================  ==============  =====================================
    stack                                 model           why
    ====================================  ==============  =====================================
    any coat scatters (sigma_s > 0)       tm6             secondary fluxes (forward and back
                                                          scattering); Belcour 2018's medium
                                                          operator in the adding family keeps
                                                          single forward scattering only
    one isotropic coat over an            endf            the refractions' Jacobians through
    isotropic dielectric base (coated                     both interfaces: the transmitted side
    glass, a glass plate)                                 far closer than the adding family's,
                                                          the reflected side about the same
    interfaces, absorbing coats, any      yamaguchi2019   2x2 covariance: follows rotated
    base                                                  anisotropy; the adding-doubling
                                                          family is best on these cases
    ====================================  ==============  =====================================
    """
    if stack.has_scattering:
        return "tm6"
    if (stack.base.kind.transmits and len(stack.coats) == 1
            and all(layer.roughness[0] == layer.roughness[1] for layer in (stack.coats[0], stack.base))):
        return "endf"
    return "yamaguchi2019"


def get(name: str):
    """The registered model ``name`` (``"auto"`` is not resolved here: see ``resolve``)."""
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; available: {', '.join(['auto', *MODELS])}")
    return MODELS[name]


def resolve(model, stack):
    """A model object for a name (``"auto"`` chosen by structure) or a model object itself."""
    if not isinstance(model, str):
        return model
    return get(choose_auto(stack) if model == "auto" else model)


def variant(name: str, mapping: str | None = None, tir: bool | None = None) -> Variant:
    """An adding-doubling variant by name, optionally with another roughness<->variance mapping
    or TIR switch (for studies; the registry holds the published ones)."""
    v = get("yamaguchi2019" if name == "auto" else name)
    if not isinstance(v, Variant):
        raise ValueError(f"{name!r} is not an adding-doubling variant")
    if mapping is not None:
        v = Variant(v.name, v.spread, MAPPINGS[mapping], v.tir)
    if tir is not None:
        v = Variant(v.name, v.spread, v.mapping, tir)
    return v


def run_model(ops, stack, wi, model) -> list[Lobe]:
    return resolve(model, stack).run(ops, stack, wi)


from ..lobe_kinds import eval_lobes_cos  # noqa: E402  (the lobe table imports models.fgd)

__all__ = ["Lobe", "UnsupportedStack", "Variant", "MODELS", "VARIANTS", "choose_auto", "get", "resolve",
           "variant", "run_model", "eval_lobes_cos", "RGB"]
