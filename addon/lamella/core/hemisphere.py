"""The half-vector grid of outgoing directions over the upper hemisphere on which lobes are compared
(docs/design.md "Metrics"): the accuracy suite measures the models on it, and the lobe budget
checks merged lobes on it."""
from __future__ import annotations

import math

import numpy as np


def wo_grid(wi: np.ndarray, n_theta: int = 16, n_phi: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Outgoing directions and their solid angles, parameterised by the half vector h (a midpoint
    grid with theta_h = (pi/2) t^2, so cells crowd around the mirror direction where every lobe
    of a layered stack is centred). wo = reflect(wi, h), d omega_o = 4 (wi . h) d omega_h; cells
    whose wo falls below the horizon are dropped. The weights integrate any f over the upper
    hemisphere: sum(f * weight) ~ integral of f d omega_o."""
    t = (np.arange(n_theta) + 0.5) / n_theta
    th = 0.5 * math.pi * t * t
    dth = 0.5 * math.pi * 2.0 * t / n_theta
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], -1).reshape(-1, 3)
    d_omega_h = (np.sin(TH) * dth[:, None] * (2.0 * math.pi / n_phi)).ravel()
    c = h @ wi
    wo = 2.0 * c[:, None] * h - wi
    weight = 4.0 * c * d_omega_h
    keep = (wo[:, 2] > 1e-6) & (c > 0)
    return wo[keep], weight[keep]
