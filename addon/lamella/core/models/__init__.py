"""The layered models, written once over the abstract ops (no numpy import anywhere in here).

``MODELS`` is the registry of model families by public name (``lamella.core.registry``); each
entry has ``name`` and ``run(ops, stack, wi) -> list[Lobe]`` (``types.Lobe``) and traces and
evaluates on any backend. A new model is one module whose object joins with :func:`register`. ``auto`` resolves to a
registered model by the stack's structure alone (``choose_auto``). Lobes are evaluated through
the lobe-kind table (``lamella.core.lobe_kinds``).
"""
from __future__ import annotations

from dataclasses import replace

from ..registry import Registry, require_callables
from . import coverage
from .adding_doubling import BELCOUR2018, WEIER2020, YAMAGUCHI2019, YAMAGUCHI_REFINED, Variant
from .endf import ENDF
from .rgb import RGB
from .roughness import MAPPINGS
from .sides import OUTSIDE, view_of
from .transfer_matrix import TransferMatrix
from .types import Lobe, UnsupportedStack


def _complete(model) -> None:
    require_callables("model", model, "run")
    if getattr(model, "name", None) == "auto":
        raise ValueError("'auto' is the model chosen by a stack's structure, not a model name")


MODELS: Registry = Registry("model", _complete)


def register(model):
    """Add a model (an object with ``name`` and ``run(ops, stack, wi) -> list[Lobe]``): the API,
    the shaders, the Blender model menu and the benches then offer it."""
    return MODELS.register(model)


def unregister(model_or_name) -> None:
    """Remove a model registered by :func:`register`."""
    MODELS.unregister(model_or_name)


# tm6 with the light no medium has scattered carried by yamaguchi_refined (``transfer_matrix``, ``primary``)
TM6_REFINED = TransferMatrix("tm6_refined", six_flux=True, primary=YAMAGUCHI_REFINED)
for _model in (BELCOUR2018, WEIER2020, YAMAGUCHI2019, YAMAGUCHI_REFINED, TransferMatrix("tm2", six_flux=False),
               TransferMatrix("tm6", six_flux=True), TM6_REFINED, ENDF()):
    register(_model)
VARIANTS = {k: v for k, v in MODELS.items() if isinstance(v, Variant)}  # the adding-doubling family


def choose_auto(stack) -> str:
    """The model ``auto`` runs for ``stack``: a pure function of the stack's structure, so a
    shader traced with ``auto`` is static code. Decision table (measured in bench/accuracy.md):

    ====================================  ==============  =====================================
    stack                                 model           why
    ====================================  ==============  =====================================
    any coat scatters (sigma_s > 0)       tm6_refined     secondary fluxes (forward and back
                                                          scattering) by tm6; Belcour 2018's
                                                          medium operator in the adding family
                                                          keeps single forward scattering only;
                                                          the unscattered light through the
                                                          interfaces by yamaguchi_refined
    one isotropic coat over an            endf            the refractions' Jacobians through
    isotropic dielectric base (coated                     both interfaces: the transmitted side
    glass, a glass plate)                                 far closer than the adding family's,
                                                          the reflected side about the same
    interfaces, absorbing coats, any      yamaguchi_      2x2 covariance: follows rotated
    base                                  refined         anisotropy; the adding-doubling
                                                          family is best on these cases, and
                                                          Yamaguchi et al. 2019 with the
                                                          refinements of
                                                          bench/interface_variants.md best
                                                          of it
    ====================================  ==============  =====================================

    A thin-walled base is decided as the sheet it stands for (``sides.view_of``: a coat of its
    index over a base of index 1), so every caller names the model that runs.
    """
    stack = view_of(stack, OUTSIDE)
    if stack.has_scattering:
        return TM6_REFINED.name
    if (stack.base.kind.transmits and len(stack.coats) == 1
            and all(layer.roughness[0] == layer.roughness[1] for layer in (stack.coats[0], stack.base))):
        return "endf"
    return YAMAGUCHI_REFINED.name


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


def variant(name: str, mapping=None, tir: bool | None = None, **refinements) -> Variant:
    """An adding-doubling variant by name, optionally with another roughness<->variance mapping
    (a name of ``roughness.MAPPINGS`` or a ``roughness.Mapping``), TIR switch or refinements
    (``adding_doubling.Variant``'s ``jacobians``, ``refraction_spread``, ``grazing``), for studies;
    the registry holds the published ones."""
    v = get(YAMAGUCHI_REFINED.name if name == "auto" else name)
    if not isinstance(v, Variant):
        raise ValueError(f"{name!r} is not an adding-doubling variant")
    changes = dict(refinements)
    if mapping is not None:
        changes["mapping"] = MAPPINGS[mapping] if isinstance(mapping, str) else mapping
    if tir is not None:
        changes["tir"] = tir
    return replace(v, **changes)


def run_model(ops, stack, wi, model, partial=None, seen_from=OUTSIDE) -> list[Lobe]:
    """The lobes of ``stack`` under ``model`` (a name, ``"auto"`` or a model object), with the
    partly covering coats (``coverage.partial_coats``; ``partial`` overrides) mixed in: each
    lobe's ``cover`` is the fraction of the surface it is on. ``seen_from``: the side of the
    surface the view is on (``sides``: "inside" sees a solid dielectric base from within)."""
    return coverage.run(ops, stack, wi, model, resolve, partial, seen_from)


__all__ = ["Lobe", "UnsupportedStack", "Variant", "MODELS", "VARIANTS", "register", "unregister", "choose_auto",
           "get", "resolve", "variant", "run_model", "RGB"]
