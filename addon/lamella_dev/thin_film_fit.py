"""The fit of the thin film's spectral sensitivities, ``SENSITIVITY_LOBES`` of
``lamella.core.models.thin_film``: reproducible, development only.

What is fitted. The RGB model integrates the film's Airy series (Belcour and Barla 2017, Eq. 10)
against each channel's colour matching function analytically. With R(lambda) = C_0 +
2 sum_m C_m cos(m (2 pi OPD / lambda + phi)) and the channel c = int R rbar_c dlambda / int rbar_c
dlambda, the terms need

    S_c(x) = int rbar_c(lambda) exp(2 pi i x / lambda) dlambda / int rbar_c(lambda) dlambda
           = int g_c(nu) exp(2 pi i x nu) dnu / int g_c(nu) dnu,   g_c(nu) = rbar_c(1 / nu) / nu^2,

at x = m OPD: the Fourier transform, over the wavenumber nu = 1 / lambda, of the colour matching
function's density per unit wavenumber, normalised to 1 at x = 0 (R_c = C_0 + 2 sum_m C_m
Re(exp(i m phi) S_c(m OPD))). rbar_c = the CIE 1931 2-degree XYZ functions through Cycles' XYZ ->
Rec.709 matrix. Belcour and Barla (supplemental code) write the transform of each XYZ function as a
sum of Gaussian lobes, each the transform of a Gaussian in nu:

    xhat(x) = sum_j val_j sqrt(2 pi var_j) exp(-var_j phi^2) exp(i pos_j phi),   phi = 2 pi x,

x in metres, pos_j the lobe's centre wavenumber (1/m), var_j = s_j^2 / 2 for the Gaussian's
standard deviation s_j in nu, val_j sqrt(2 pi var_j) the lobe's share of int xbar dlambda
(lambda in metres). Their fit has one lobe for y and z and two for x; the model maps the lobes'
sum through the matrix and divides each RGB channel by its value at x = 0 (so a flat spectrum
stays grey). This module fits ``--lobes`` N lobes per XYZ function, the same form, by least
squares on what the model uses: the complex RGB sensitivities after the matrix and that
normalisation, against the exact transform of the tabulated functions (the sum over the 1 nm CIE
table, 360-830 nm, that ``lamella_dev.thin_film_spectral`` integrates against and Cycles'
``compute_thin_film_table`` tabulates), real and imaginary parts, the three channels weighted
alike.

The OPD range. The model evaluates S_c at m OPD, m = 1..ORDERS (3), OPD = 2 n_film d cos(theta_film)
<= 2 n_film d; its tests take films up to n_film = 3 and d = 5000 nm, so x reaches
ORDERS * 2 * 3 * 5000 nm = 90 um (``OPD_MAX_NM``). The exact transform is below 0.01 of its DC value
from 8 um on and below 1e-4 from 30 um on, so the far part of the range only keeps the lobes from
ringing there. The samples are uniform in x (every 20 nm; the transform's fastest period is
360 nm): for a uniform spread of thicknesses that is how the first order, which dominates, meets
the sensitivity, and by Parseval a uniform least-squares fit in x over the whole line is the
least-squares fit of the spectral density itself (which is how the starting points are found).

Run (from the repository root; scipy comes with colour-science):

    PYTHONPATH=addon python -m lamella_dev.thin_film_fit --lobes 2 3

It prints, per N, the constants as Python source (rounded as printed, and the errors are those of
the rounded constants) and the errors of the RGB sensitivities against the exact transform, next to
the paper's fit and the model's current constants.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from .thin_film_spectral import XYZ_TO_REC709, cmfs

# Belcour and Barla 2017, supplemental code (the model's constants until this fit replaced them):
# (XYZ axis, val, pos, var) per lobe, the units of the module's docstring.
PAPER_LOBES = ((0, 5.4856e-13, 1.6810e+06, 4.3278e+09),
               (1, 4.4201e-13, 1.7953e+06, 9.3046e+09),
               (2, 5.2481e-13, 2.2084e+06, 6.6121e+09),
               (0, 9.7470e-14, 2.2399e+06, 4.5282e+09))

ORDERS = 3
FILM_IOR_MAX = 3.0
THICKNESS_MAX_NM = 5000.0
OPD_MAX_NM = ORDERS * 2.0 * FILM_IOR_MAX * THICKNESS_MAX_NM  # 90 um
OPD_STEP_NM = 20.0
MAX_NFEV = 150  # the starts that converge take 20-60 evaluations
DIGITS = 6  # significant digits of the printed constants

_TO_PHI = 2.0 * math.pi * 1e-9  # phi per nm of OPD


def _xyz_table():
    """(wavelengths in nm, (L, 3) XYZ colour matching functions) on 360-830 nm every 1 nm."""
    import colour

    table = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    lam = np.asarray(table.wavelengths, dtype=np.float64)
    xyz = np.asarray(table.values, dtype=np.float64)
    keep = (lam >= 360.0) & (lam <= 830.0)
    return lam[keep], xyz[keep]


def exact_sensitivity(opd_nm: np.ndarray) -> np.ndarray:
    """(K, 3) complex: the exact normalised RGB sensitivities S_c at the OPDs (nm), the sum over the
    1 nm table (the spectral reference's integral)."""
    lam, w = cmfs(1)
    out = [np.exp(2j * np.pi * chunk[:, None] / lam) @ w for chunk in np.array_split(opd_nm, max(1, opd_nm.size // 500))]
    return np.concatenate(out)


def rgb_sensitivity(lobes, opd_nm: np.ndarray) -> np.ndarray:
    """(K, 3) complex: the model's S_c for a table of lobes (axis, val, pos, var), the arithmetic
    of ``thin_film.sensitivity`` in numpy."""
    x = np.asarray(opd_nm, dtype=np.float64)[:, None]
    axis = np.array([lobe[0] for lobe in lobes])
    val, pos, var = (np.array([lobe[i] for lobe in lobes], dtype=np.float64) for i in (1, 2, 3))
    amp = val * np.sqrt(2.0 * np.pi * var)
    g = np.exp(-(var * _TO_PHI * _TO_PHI) * x * x) * np.exp(1j * (pos * _TO_PHI) * x)
    w = np.array(XYZ_TO_REC709)[:, axis] * amp  # (3, J)
    w = w / w.sum(1, keepdims=True)
    return g @ w.T


# ---------------------------------------------------------------- the internal parameters
# Per lobe: a (its share of int xbar dlambda, lambda in nm), nu (centre wavenumber, 1/um) and
# log L (the lobe's decay length in um: exp(-(x / L)^2)).

def _to_lobes(axes, p) -> tuple:
    a, nu, log_l = p.reshape(-1, 3).T
    pos = nu * 1e6
    var = 1.0 / ((np.exp(log_l) * 1e3) ** 2 * _TO_PHI * _TO_PHI)
    val = a * 1e-9 / np.sqrt(2.0 * np.pi * var)
    return tuple((int(ax), float(v), float(q), float(s)) for ax, v, q, s in zip(axes, val, pos, var))


def _from_lobes(lobes) -> tuple[np.ndarray, np.ndarray]:
    axes = np.array([lobe[0] for lobe in lobes])
    p = []
    for _, val, pos, var in lobes:
        p += [val * math.sqrt(2.0 * math.pi * var) * 1e9, pos * 1e-6,
              math.log(1.0 / (math.sqrt(var) * _TO_PHI) * 1e-3)]
    return axes, np.array(p)


def _rounded(lobes, digits: int = DIGITS) -> tuple:
    return tuple((ax, *(float(f"{v:.{digits - 1}e}") for v in rest)) for ax, *rest in lobes)


def _start(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Starting lobes: per XYZ function a least-squares fit of n Gaussians to its density over the
    wavenumber, g(nu) = xbar(1000 / nu) 1000 / nu^2 (nu in 1/um), from random centres under it."""
    from scipy.optimize import least_squares

    lam, xyz = _xyz_table()
    nu = np.linspace(1000.0 / 830.0, 1000.0 / 360.0, 1200)
    axes, p = [], []
    for k in range(3):
        g = np.interp(nu, (1000.0 / lam)[::-1], xyz[::-1, k]) * 1000.0 / nu ** 2
        mass = np.cumsum(g) / g.sum()
        mu0 = np.interp(np.sort(rng.uniform(0.05, 0.95, n)), mass, nu)
        q0 = np.concatenate([np.full(n, g.max() / n), mu0, np.full(n, 0.08)])

        def res(q, g=g):
            h, mu, sd = q[:n], q[n:2 * n], q[2 * n:]
            return (h[None, :] * np.exp(-0.5 * ((nu[:, None] - mu) / sd) ** 2)).sum(1) - g

        lo = np.concatenate([np.full(n, -np.inf), np.full(n, nu[0]), np.full(n, 0.01)])
        hi = np.concatenate([np.full(n, np.inf), np.full(n, nu[-1]), np.full(n, 0.5)])
        q = least_squares(res, q0, bounds=(lo, hi), method="trf").x
        h, mu, s = q[:n], q[n:2 * n], q[2 * n:]
        for j in range(n):  # the transform of h exp(-(nu - mu)^2 / 2 s^2): h s sqrt(2 pi), decay length 1 / (pi s sqrt 2)
            axes.append(k)
            p += [h[j] * s[j] * math.sqrt(2.0 * math.pi), mu[j], math.log(1.0 / (math.pi * s[j] * math.sqrt(2.0)))]
    return np.array(axes), np.array(p)


def _problem(axes, opd, target):
    """The residuals (real and imaginary parts of S_c - exact, every OPD and channel, and one row
    fixing the free overall scale, which the normalisation cancels: y's lobes sum to int ybar
    dlambda at 0, as the paper's) and their Jacobian."""
    m = np.array(XYZ_TO_REC709)[:, axes]  # (3, J)
    x = opd[:, None] * 1e-3  # um
    y_dc = float(_xyz_table()[1][:, 1].sum())
    is_y = (axes == 1).astype(np.float64)

    def parts(p):
        a, nu, log_l = p.reshape(-1, 3).T
        inv_l2 = np.exp(-2.0 * log_l)
        g = np.exp(-(x * x) * inv_l2) * np.exp(2j * np.pi * nu * x)  # (K, J)
        w = m * a
        dc = w.sum(1)  # (3,)
        s = (g @ w.T) / dc
        return a, inv_l2, g, w, dc, s

    def res(p):
        a, _, _, _, _, s = parts(p)
        d = s - target
        return np.concatenate([d.real.ravel(), d.imag.ravel(), [1e-2 * (is_y @ a / y_dc - 1.0)]])

    def jac(p):
        a, inv_l2, g, w, dc, s = parts(p)
        k, j = g.shape
        out = np.empty((k, 3, j, 3), dtype=np.complex128)  # (OPD, channel, lobe, parameter)
        for c in range(3):
            out[:, c, :, 0] = m[c] * (g - s[:, c:c + 1]) / dc[c]
            gw = g * (w[c] / dc[c])
            out[:, c, :, 1] = gw * (2j * np.pi * x)
            out[:, c, :, 2] = gw * (2.0 * x * x * inv_l2)
        out = out.reshape(k * 3, j * 3)
        gauge = np.zeros((1, j * 3))
        gauge[0, 0::3] = 1e-2 * is_y / y_dc
        return np.concatenate([out.real, out.imag, gauge])

    return res, jac


def fit(n: int, opd_max: float = OPD_MAX_NM, step: float = OPD_STEP_NM, starts: int = 8, seed: int = 1) -> tuple:
    """The least-squares fit with ``n`` lobes per XYZ function over OPD in [0, opd_max] nm, the best
    of ``starts`` starting points: the lobes as (axis, val, pos, var), sorted by axis and centre, and
    every start's final cost (half the sum of squared residuals), least first."""
    from scipy.optimize import least_squares

    opd = np.arange(0.0, opd_max + 0.5 * step, step)
    target = exact_sensitivity(opd)
    rng = np.random.default_rng(seed)
    best, costs = None, []
    for _ in range(starts):
        axes, p0 = _start(n, rng)
        res, jac = _problem(axes, opd, target)
        with np.errstate(over="ignore", invalid="ignore"):  # a start that runs away is dropped
            sol = least_squares(res, p0, jac=jac, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=MAX_NFEV)
        costs.append(sol.cost)
        if np.isfinite(sol.cost) and (best is None or sol.cost < best[0]):
            best = (sol.cost, axes, sol.x)
    _, axes, p = best
    lobes = _to_lobes(axes, p)
    return tuple(sorted(lobes, key=lambda lobe: (lobe[0], lobe[2]))), sorted(costs)


# ---------------------------------------------------------------- the report
RANGES = ((0.0, 6000.0), (0.0, 30000.0), (0.0, OPD_MAX_NM))


def errors(lobes) -> dict:
    """{(lo, hi): (per-channel max |dS|, rms |dS| over the channels)} of a table of lobes."""
    opd = np.arange(0.0, OPD_MAX_NM + 0.5 * OPD_STEP_NM, OPD_STEP_NM)
    err = np.abs(rgb_sensitivity(lobes, opd) - exact_sensitivity(opd))
    out = {}
    for lo, hi in RANGES:
        e = err[(opd >= lo) & (opd <= hi)]
        out[lo, hi] = (e.max(0), float(np.sqrt(np.mean(e * e))))
    return out


def source(lobes) -> str:
    rows = [f"({ax}, {val:.{DIGITS - 1}e}, {pos:.{DIGITS - 1}e}, {var:.{DIGITS - 1}e})" for ax, val, pos, var in lobes]
    return "SENSITIVITY_LOBES = (" + ",\n                     ".join(rows) + ")"


def _print_errors(name: str, lobes) -> None:
    for (lo, hi), (mx, rms) in errors(lobes).items():
        print(f"  {name:<22} OPD {lo / 1000:>4.0f}-{hi / 1000:<3.0f} um: max |dS| R G B "
              f"{mx[0]:.4f} {mx[1]:.4f} {mx[2]:.4f}, rms {rms:.5f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m lamella_dev.thin_film_fit", description=__doc__.split("\n\n")[0])
    ap.add_argument("--lobes", type=int, nargs="+", default=[2, 3], help="lobes per XYZ function (default 2 3)")
    ap.add_argument("--opd-max", type=float, default=OPD_MAX_NM, help="the fit's OPD range, nm (default %(default)s)")
    ap.add_argument("--starts", type=int, default=8, help="starting points per fit (default %(default)s)")
    args = ap.parse_args(argv)

    from lamella.core.backends.numpy_ops import NumpyOps
    from lamella.core.models import thin_film as tf

    opd = np.arange(0.0, 20000.0, 10.0)
    model = np.stack([re + 1j * im for re, im in tf.sensitivity(NumpyOps(), opd)], -1)
    same = np.abs(model - rgb_sensitivity(tf.SENSITIVITY_LOBES, opd)).max()
    assert same < 1e-12, same  # this module evaluates the lobes as the model does
    print(f"RGB sensitivities against the exact transform of the 1 nm CIE 1931 table, fitted over OPD 0-"
          f"{args.opd_max / 1000:g} um every {OPD_STEP_NM:g} nm")
    _print_errors("paper (4 lobes)", PAPER_LOBES)
    _print_errors(f"model ({len(tf.SENSITIVITY_LOBES)} lobes)", tf.SENSITIVITY_LOBES)
    for n in args.lobes:
        lobes, costs = fit(n, opd_max=args.opd_max, starts=args.starts)
        lobes = _rounded(lobes)
        print(f"\n# {n} lobes per XYZ function ({3 * n} lobes); the starts' costs: "
              + " ".join(f"{c:.4g}" for c in costs))
        print(source(lobes) + ("  # = the model's" if lobes == tuple(tf.SENSITIVITY_LOBES) else ""))
        _print_errors(f"fit ({3 * n} lobes)", lobes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
