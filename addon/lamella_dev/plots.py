"""BRDF slice plots: each model against the stochastic reference (`lamella plot`)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from lamella.core import api
from . import reference
from lamella.core.models import UnsupportedStack, choose_auto
from lamella.core.stack import Stack

LUMA = np.array([0.2126, 0.7152, 0.0722])


def slice_directions(theta_deg: float, plane: str, n: int = 121) -> tuple[np.ndarray, np.ndarray]:
    """wo along the incidence plane ("in") or across it through the mirror direction ("perp"),
    or along the incidence plane below the surface ("trans", the transmitted side of a dielectric
    base); returns (signed angle in degrees, wo). In the incidence plane the mirror direction
    sits at +theta_i; below it, the straight-through direction does."""
    s = np.radians(np.linspace(-89.0, 89.0, n))
    t = math.radians(theta_deg)
    if plane == "trans":
        wo = np.stack([-np.sin(s), 0.0 * s, -np.cos(s)], -1)
        keep = wo[:, 2] < -1e-4
        return np.degrees(s[keep]), wo[keep]
    if plane == "in":
        wo = np.stack([-np.sin(s), 0.0 * s, np.cos(s)], -1)
    else:
        m = np.array([-math.sin(t), 0.0, math.cos(t)])
        b = np.array([0.0, 1.0, 0.0])
        wo = np.cos(s)[:, None] * m + np.sin(s)[:, None] * b
    keep = wo[:, 2] > 1e-4
    return np.degrees(s[keep]), wo[keep]


PLANE_TITLES = {"in": "incidence plane", "perp": "perpendicular plane", "trans": "transmitted, incidence plane"}
PLANE_AXES = {"in": "θo (deg, mirror at +θi)", "perp": "angle from mirror (deg)",
              "trans": "θo below (deg, straight through at +θi)"}
COLORS = {"belcour2018": "tab:blue", "weier2020": "tab:orange", "yamaguchi2019": "tab:green", "tm2": "tab:purple",
          "tm6": "tab:red", "tm6_refined": "tab:pink", "endf": "tab:brown"}


REFERENCE_STYLES = {"multiple": dict(color="k", lw=1.0, ls="-"), "single": dict(color="0.45", lw=0.9, ls=":")}
REFERENCE_LABELS = {"multiple": "reference (interfaces scatter until light leaves)",
                    "single": "reference (interfaces scatter once)"}


def plot_stack(stack, out: Path, models=("auto", "belcour2018", "weier2020", "yamaguchi2019", "tm6", "endf"),
               thetas=(0.0, 30.0, 60.0, 75.0), spp: int = 512, seed: int = 7, title: str | None = None,
               interfaces=("multiple", "single")) -> Path:
    """Slices of every model that supports the stack against the reference (log scale), for each
    setting of its rough interfaces in ``interfaces`` (``reference.INTERFACES``; the first gets the
    ±2σ band); a third row of transmitted slices for a dielectric base. ``auto`` is drawn as a
    solid line and named after the model it runs; models that refuse the stack are left out."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stack = Stack.coerce(stack)
    planes = ("in", "perp", "trans") if stack.base.kind.transmits else ("in", "perp")
    fig, axes = plt.subplots(len(planes), len(thetas), figsize=(4.2 * len(thetas), 3.5 * len(planes)), squeeze=False)
    for col, th in enumerate(thetas):
        wi = np.array([math.sin(math.radians(th)), 0.0, math.cos(math.radians(th))])
        for row, plane in enumerate(planes):
            ax = axes[row, col]
            s, wo = slice_directions(th, plane)
            top = 1e-3
            for k, itf in enumerate(interfaces):
                mean, err = reference.eval_brdf_cos(stack, wi, wo, spp=spp, seed=seed + 17 * col + row,
                                                    interfaces=itf)
                y, e = mean @ LUMA, np.sqrt((err ** 2) @ (LUMA ** 2))
                if k == 0:
                    ax.fill_between(s, np.maximum(y - 2 * e, 1e-6), y + 2 * e, color="0.85", label="±2σ")
                ax.plot(s, y, label=REFERENCE_LABELS[itf], **REFERENCE_STYLES[itf])
                top = max(top, float(y.max()))
            for m in models:
                try:
                    f = api.evaluate(stack, wi, wo, m) @ LUMA
                except UnsupportedStack:
                    continue
                if m == "auto":
                    ax.plot(s, f, color="tab:cyan", lw=2.0, alpha=0.8, label=f"auto ({choose_auto(stack)})")
                else:
                    ax.plot(s, f, color=COLORS.get(m), lw=1.2, ls="--", label=m)
            ax.set_yscale("log")
            ax.set_ylim(top * 1e-4, top * 3)
            ax.set_title(f"θi = {th:g}°, {PLANE_TITLES[plane]}", fontsize=9)
            ax.set_xlabel(PLANE_AXES[plane])
            if col == 0:
                ax.set_ylabel("f · cos θo (luminance)")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    fig.suptitle(title or stack.name or "stack", fontsize=11)
    return save_figure(fig, out, dpi=90)


def save_figure(fig, out: Path, dpi: int = 90) -> Path:
    """Lay out, write (creating the folder) and close a matplotlib figure."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def contact_sheet(images: dict, out: Path, captions: dict | None = None, ncols: int = 4, title: str = "") -> Path:
    """A grid of renders (name -> linear RGBA), tone-mapped like the image metrics
    (``image_metrics.display_srgb``), each captioned with its name and ``captions[name]``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .image_metrics import display_srgb

    names = list(images)
    nrows = max(1, math.ceil(len(names) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.6 * ncols, 2.9 * nrows), squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, name in zip(axes.ravel(), names):
        ax.imshow(display_srgb(images[name]))
        cap = name + (f"\n{captions[name]}" if captions and name in captions else "")
        ax.set_title(cap, fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    return save_figure(fig, out, dpi=100)
