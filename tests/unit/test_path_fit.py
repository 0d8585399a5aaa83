"""The floor of a model's closures (``lamella_dev.path_fit``): it recovers lobes it can express
exactly, is never above the model's own error, and leaves out what a pointwise metric cannot see."""
import numpy as np

from lamella.core import api
from lamella.core.models.types import Lobe
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core import lobe_kinds
from lamella_dev import path_fit, suite
from lamella_dev.bench.accuracy import load_reference, reference_by_symmetry
from lamella_dev.bench.paths import REFERENCE_DIR_MULTIPLE


def _grid(deg):
    wi = suite.incident(deg)
    wo, w = suite.wo_grid(wi)
    return wi, wo, w


def _lobes_cos(wi, wo, kinds, alphas, energies):
    ops = NumpyOps(np.float64)
    wib = np.broadcast_to(wi, wo.shape)
    wi_v = tuple(ops.input(n, wib[:, j]) for j, n in enumerate(("wi_x", "wi_y", "wi_z")))
    wo_v = tuple(ops.input(n, wo[:, j]) for j, n in enumerate(("wo_x", "wo_y", "wo_z")))
    total = np.zeros(wo.shape)
    for kind, a, e in zip(kinds, alphas, energies):
        v = np.asarray(lobe_kinds.kind(kind).closure_cos(ops, Lobe((1.0, 1.0, 1.0), a, a, 0.0, kind), wi_v, wo_v))
        total += np.asarray(e)[None, :] * np.broadcast_to(v, wo.shape[:1])[:, None]
    return total


def test_lobes_of_the_models_kinds_are_fitted_exactly():
    """A 'reference' made of the model's two GGX lobes at roughnesses of the scan and other
    energies: the fit finds it (relative L1 ~ 0; the model's diffuse lobe, the conductor's
    multiple scattering, gets no energy) where the model's lobes are far from it."""
    stack = suite.load("gold_coated")
    wi, wo, w = _grid(45.0)
    alphas = (float(path_fit.ALPHAS[30]), float(path_fit.ALPHAS[45]))
    f_ref = _lobes_cos(wi, wo, ("reflection", "reflection"), alphas, ([0.05, 0.05, 0.05], [0.6, 0.4, 0.2]))
    fit = path_fit.fit_paths(stack, wi, wo, w, f_ref)
    assert fit.rel_l1_model > 0.2
    assert fit.rel_l1 < 1e-3, fit
    rough = [a[0] for a, kind in zip(fit.alphas, fit.kinds) if kind == "reflection"]
    assert sorted(rough) == sorted(alphas)


def test_the_floor_is_never_above_the_models_error_and_leaves_deltas_out():
    for name, deg in (("gold_coated", 60.0), ("green_scatter_d6", 0.0), ("rough_glass_plate", 30.0)):
        stack = suite.load(name)
        ref = load_reference(name, REFERENCE_DIR_MULTIPLE)
        i = list(ref["wi_degrees"]).index(deg)
        f_ref, _ = reference_by_symmetry(ref, i, stack)
        wi = suite.incident(deg)
        fit = path_fit.fit_paths(stack, wi, ref[f"wo_{i}"], ref[f"weight_{i}"], f_ref)
        model = api.evaluate(stack, wi, ref[f"wo_{i}"], "auto", deltas=False)
        from lamella_dev.metrics import relative_l1
        assert abs(fit.rel_l1_model - relative_l1(model, f_ref, ref[f"weight_{i}"])) < 1e-12
        assert 0.0 < fit.rel_l1 <= fit.rel_l1_model, (name, fit)
        lb = api.lobes(stack, wi)
        smooth = sum(1 for k, kind in enumerate(lb.kinds) if lobe_kinds.kind(kind).rough and lb.alpha_x[0, k] == 0.0)
        reflected = sum(1 for kind in lb.kinds if lobe_kinds.kind(kind).side == "reflected")
        assert len(fit.kinds) == reflected - smooth  # deltas and the transmitted side left out
        assert all(np.all(np.asarray(e) >= 0.0) for e in fit.energies)
