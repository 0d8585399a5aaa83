"""The floor of a model's closures (``lamella_dev.path_fit``): it recovers lobes it can express
exactly, is never above the model's own error, and leaves out what a pointwise metric cannot see."""
import numpy as np

from lamella.core import api
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core import lobe_kinds
from lamella_dev import path_fit, suite
from lamella_dev.metrics import relative_l1
from lamella_dev.bench.accuracy import load_reference, reference_by_symmetry
from lamella_dev.bench.paths import REFERENCE_DIR_MULTIPLE


def _grid(deg):
    wi = suite.incident(deg)
    wo, w = suite.wo_grid(wi)
    return wi, wo, w


def _lobes_cos(wi, wo, w, kinds, alphas, energies):
    """Lobes of the given kinds, roughnesses and energies on the grid (energy = integral on the grid)."""
    ops = NumpyOps(np.float64)
    wi_v, wo_v = path_fit.direction_inputs(ops, wi, wo)
    return sum(np.asarray(e)[None, :] * path_fit.lobe_shape(ops, wi_v, wo_v, w, kind, a, a, 0.0)[:, None]
               for kind, a, e in zip(kinds, alphas, energies))


def test_lobes_of_the_models_kinds_are_fitted_exactly():
    """A 'reference' made of the model's two GGX lobes at roughnesses of the scan and other
    energies: the fit finds it (relative L1 ~ 0; the model's diffuse lobe, the conductor's
    multiple scattering, gets no energy) where the model's lobes are far from it."""
    stack = suite.load("gold_coated")
    wi, wo, w = _grid(45.0)
    alphas = (float(path_fit.ALPHAS[30]), float(path_fit.ALPHAS[45]))
    f_ref = _lobes_cos(wi, wo, w, ("reflection", "reflection"), alphas, ([0.05, 0.05, 0.05], [0.6, 0.4, 0.2]))
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
        assert abs(fit.rel_l1_model - relative_l1(model, f_ref, ref[f"weight_{i}"])) < 1e-12
        assert 0.0 < fit.rel_l1 <= fit.rel_l1_model, (name, fit)
        lb = api.lobes(stack, wi)
        smooth = sum(1 for k, kind in enumerate(lb.kinds) if lobe_kinds.kind(kind).rough and lb.alpha_x[0, k] == 0.0)
        reflected = sum(1 for kind in lb.kinds if lobe_kinds.kind(kind).side == "reflected")
        assert len(fit.kinds) == reflected - smooth  # deltas and the transmitted side left out
        assert all(np.all(np.asarray(e) >= 0.0) for e in fit.energies)


def test_the_partial_fits_hold_what_they_say():
    """``fit="roughness"`` keeps every lobe's energy on the grid (the model's lobe's), ``fit="energies"``
    every roughness; on a stack whose base lobe is too broad at normal incidence (frosted_metal)
    the widths alone take most of the way to the floor and the energies alone do not."""
    stack = suite.load("frosted_metal")
    ref = load_reference("frosted_metal", REFERENCE_DIR_MULTIPLE)
    f_ref, _ = reference_by_symmetry(ref, 0, stack)
    args = (stack, suite.incident(0.0), ref["wo_0"], ref["weight_0"], f_ref)
    both, widths, energies = (path_fit.fit_paths(*args, fit=f) for f in ("both", "roughness", "energies"))
    assert energies.alphas == energies.alphas_model
    # the lobes' energies on the grid: their weights less what falls below the horizon or between cells
    lb = api.lobes(stack, args[1])
    np.testing.assert_allclose(widths.energies, lb.weight[0], rtol=0.02)
    assert widths.alphas != widths.alphas_model
    assert both.rel_l1 <= energies.rel_l1 <= energies.rel_l1_model
    assert widths.rel_l1 < both.rel_l1 + 0.05 < energies.rel_l1, (both.rel_l1, widths.rel_l1, energies.rel_l1)
