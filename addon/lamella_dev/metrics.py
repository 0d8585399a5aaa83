"""Error metrics of docs/design.md ("Metrics"), BRDF space."""
from __future__ import annotations

import numpy as np


def relative_l1(f: np.ndarray, f_ref: np.ndarray, weight: np.ndarray) -> float:
    """sum |f - f_ref| d omega / sum f_ref d omega over a direction grid, RGB averaged."""
    num = (np.abs(f - f_ref) * weight[:, None]).sum(0)
    den = (f_ref * weight[:, None]).sum(0)
    return float(np.mean(num / np.maximum(den, 1e-30)))


def albedo_error(a: np.ndarray, a_ref: np.ndarray) -> float:
    """Relative error of the directional albedo, RGB averaged: mean(|a - a_ref| / a_ref)."""
    return float(np.mean(np.abs(a - a_ref) / np.maximum(a_ref, 1e-30)))
