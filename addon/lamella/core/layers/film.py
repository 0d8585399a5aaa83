"""The thin film a layer with an interface may carry on it: ``film_thickness`` (nm; 0, the
default, is no film) and ``film_ior``. The models read it as the interface's reflectance
(``models.film``, after Belcour and Barla 2017); a layer without a film traces to no film code."""
from __future__ import annotations

from .params import field_param
from .schema import FLOAT, Field

FILM_THICKNESS_MAX = 5000.0  # nm: past a few microns the film's colours average to grey
FILM_IOR_MIN, FILM_IOR_MAX = 1.0, 3.0  # soap and oil 1.33-1.5, oxides 1.5-2.9 (rutile)
# A film's reflectance cycles with its thickness d every lambda / (2 n cos theta_f) (the Airy sum's
# phase 4 pi n d cos theta_f / lambda): 150 nm for oil (n 1.47) at 450 nm, 90 nm for an oxide of
# n 2.5 at 450 nm. A table over a linked thickness has nodes at most this far apart, 9 a cycle of
# the oxide (linear interpolation off by (pi / 9)^2 / 8 = 1.5 % of the swing there, 0.5 % for oil).
FILM_AXIS_STEP = 10.0  # nm
# The phase moves with the film's index as 4 pi d cos theta_f / lambda: a cycle every 0.57 of index for
# the default 350 nm at 400 nm, every 0.13 at 1500 nm; a table over a linked index has nodes at most
# 0.02 apart (76 over 1-2.5), 7 a cycle at 1500 nm.
FILM_IOR_AXIS_STEP = 0.02

FIELDS = (
    Field("film_thickness", FLOAT, 0.0, "thickness of a thin film on the interface (0: none); its "
          "interference colours", "nm", lo=0.0, hi=FILM_THICKNESS_MAX, soft=(0.0, 1500.0), label="Film Thickness",
          group="Thin Film", axis_step=FILM_AXIS_STEP),
    Field("film_ior", FLOAT, 1.33, "index of refraction of the thin film (absolute)", "", lo=FILM_IOR_MIN,
          hi=FILM_IOR_MAX, soft=(1.0, 2.5), label="Film IOR", group="Thin Film", axis_step=FILM_IOR_AXIS_STEP),
)


def params(ops, slot, layer) -> dict:
    """``film_thickness`` and ``film_ior`` for a layer whose film is thicker than 0, else nothing."""
    if layer.film_thickness <= 0.0:
        return {}
    return {"film_thickness": field_param(ops, slot, "film_thickness", layer.film_thickness),
            "film_ior": field_param(ops, slot, "film_ior", layer.film_ior)}


__all__ = ["FIELDS", "params", "FILM_THICKNESS_MAX", "FILM_IOR_MIN", "FILM_IOR_MAX", "FILM_AXIS_STEP", "FILM_IOR_AXIS_STEP"]
