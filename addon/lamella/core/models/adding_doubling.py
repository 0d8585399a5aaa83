"""Adding-doubling of lobe statistics (energy, mean, spread) through a stack of rough interfaces.

The loop is Belcour 2018's ``computeAddingDoubling`` as published in paper 003 Listing 3 (which
restates it with per-axis variances) and reviewed in paper 001 Eqs. (7)-(12); the spread type
(scalar, per-axis, 2x2 covariance) selects Belcour 2018, Weier & Belcour 2020 or Yamaguchi et al.
2019 (see ``variance.py``). Written once over the abstract ops: Python control flow depends only
on the stack's structure (number of coats, which ones absorb, the base kind).

Per interface, with cti the cosine of the mean direction above it and n12 = n_below / n_above:

* energies: R12 = FGD(cti, alpha, n12) (exact Fresnel + a pre-integrated rough correction, see
  ``fgd.py``), T12 = 1 - R12; R21 = R12, T21 = T12 (Belcour's symmetric approximation); the TIR
  correction of Belcour 2018 (paper 001 after Eq. 10) moves the part of the upward transmission
  that falls outside the escape cone into the upward reflectance;
* spreads: s_r = f(alpha) for reflection, s_t12 = f(alpha |n12 - 1| / (2 n12)) and
  s_t21 = f(alpha |n12 - 1| / 2) for transmission (Belcour 2018's fake-refraction scale at normal
  incidence: a facet tilt d deviates a refracted ray by d |1 - n1/n2|, a reflected one by 2d),
  Jacobians j12 = n12 ctt / cti (Listing 3, lines 29-37);
* the adding equations of Listing 3 lines 46-76 (energies: paper 001 Eqs. 1-2 and 10; spreads:
  paper 001 Eq. 11), one output lobe per interface with energy m_R0i (the light that reached the
  interface and came back out, all orders);
* an absorbing coat interior (Beer-Lambert along the refracted mean direction, as Belcour 2018's
  medium layers without scattering): T = exp(-sigma_a d / cos), which in the adding equations
  reduces to T0i *= T, Ti0 *= T, Ri0 *= T^2 with unchanged spreads.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..stack import Conductor, Stack
from .fgd import fgd_conductor, fgd_dielectric, tir_fraction
from .rgb import RGB

COS_FLOOR = 1e-6  # smallest cosine used in a Beer-Lambert path length (keeps d / cos finite)


class UnsupportedStack(ValueError):
    """The model cannot represent this stack; the message says why."""


@dataclass
class Lobe:
    """A GGX reflection lobe of the model, in backend values: energy (RGB), roughness along its
    own axes and the angle of those axes from the shading tangent."""

    weight: RGB
    alpha_x: object
    alpha_y: object
    rotation: object
    kind: str = "reflection"


@dataclass(frozen=True)
class Variant:
    """One published variant of the statistical model."""

    name: str
    spread: type  # a class of variance.py
    mapping: object  # a roughness.Mapping
    tir: bool = True


def check_supported(stack: Stack, model_name: str) -> None:
    if not isinstance(stack.base, Conductor):
        raise UnsupportedStack(
            f"{model_name}: base '{stack.base.type}' is not supported yet (only a conductor base; "
            "diffuse and dielectric bases arrive with the scattering-media models)")
    for i, c in enumerate(stack.coats):
        if c.has_scattering:
            raise UnsupportedStack(
                f"{model_name}: coat {i} scatters (sigma_s > 0); scattering media are not "
                "supported by this model yet")


def layer_params(ops, stack: Stack):
    """Every per-layer parameter as a backend value (a shader input when traced)."""
    coats = []
    for i, c in enumerate(stack.coats):
        p = {"ior": ops.param(f"coat{i}_ior", c.ior), **_roughness_params(ops, f"coat{i}", c.roughness, c.rotation)}
        if c.has_absorption:
            p["thickness"] = ops.param(f"coat{i}_thickness", c.thickness)
            p["sigma_a"] = RGB(*(ops.param(f"coat{i}_sigma_a_{ch}", v) for ch, v in zip("rgb", c.sigma_a)))
        coats.append(p)
    b = stack.base
    base = {"eta": RGB(*(ops.param(f"base_eta_{ch}", v) for ch, v in zip("rgb", b.eta))),
            "k": RGB(*(ops.param(f"base_k_{ch}", v) for ch, v in zip("rgb", b.k))),
            **_roughness_params(ops, "base", b.roughness, b.rotation)}
    return coats, base


def _roughness_params(ops, prefix: str, roughness, rotation) -> dict:
    """An isotropic layer is one input ``<prefix>_alpha`` with no rotation (rotation has no effect
    on it): the traced shader then carries no anisotropy or rotation code for it. An anisotropic
    layer has ``_alpha_x``, ``_alpha_y`` and ``_rotation`` inputs. Which of the two a layer is,
    is part of the stack's structure (a different shader), like the number of coats."""
    ax, ay = roughness
    if ax == ay:
        a = ops.param(f"{prefix}_alpha", ax)
        return {"ax": a, "ay": a, "rotation": 0.0}
    return {"ax": ops.param(f"{prefix}_alpha_x", ax), "ay": ops.param(f"{prefix}_alpha_y", ay),
            "rotation": ops.param(f"{prefix}_rotation", rotation)}


def adding_doubling(ops, stack: Stack, wi, variant: Variant) -> list[Lobe]:
    """Lobes (one per interface, top to bottom) for the incident direction ``wi = (x, y, z)``
    (backend values, unit vector in the upper hemisphere)."""
    check_supported(stack, variant.name)
    Spread, mapping = variant.spread, variant.mapping
    coats, base = layer_params(ops, stack)

    wx, wy, wz = wi
    cti = ops.clamp(wz, 0.0, 1.0)
    sx, sy = wx, wy  # tangential part of the mean direction in the current medium
    n_above = 1.0

    # Statistics of the part of the stack already added (paper 003 Listing 3, lines 10-13)
    R0i, Ri0, T0i, Ti0 = RGB.splat(0.0), RGB.splat(0.0), RGB.splat(1.0), RGB.splat(1.0)
    s_r0i, s_ri0, s_t0i, s_ti0 = Spread.zero(), Spread.zero(), Spread.zero(), Spread.zero()
    j0i, ji0 = 1.0, 1.0

    lobes: list[Lobe] = []
    interfaces = [("coat", c) for c in coats] + [("base", base)]
    for index, (kind, p) in enumerate(interfaces):
        ops.set_scope(f"coat{index}" if kind == "coat" else "base")
        cos_r, sin_r = ops.cos(p["rotation"]), ops.sin(p["rotation"])
        ax, ay = p["ax"], p["ay"]
        fetch_mu, fetch_alpha = Spread.fgd_fetch(ops, sx, sy, cti, ax, ay, cos_r, sin_r)
        s_r12 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r)
        s_r21 = s_r12

        if kind == "coat":
            n12 = p["ior"] / n_above
            # Snell on the tangential component; beyond total internal reflection nothing
            # is transmitted and the mean direction is only carried along (finite) for the lanes
            # whose energy is already zero.
            tsx, tsy = sx / n12, sy / n12
            # ctt^2 = (n12^2 - 1 + cti^2) / n12^2: exact for index-matched interfaces at grazing
            # (the form 1 - |s_t|^2 cancels catastrophically there; see fresnel_dielectric)
            cos2_num = n12 * n12 - 1.0 + cti * cti
            transmits = cos2_num > 0.0
            ctt = ops.sqrt(ops.max(cos2_num, 0.0) / (n12 * n12))
            R12s = fgd_dielectric(ops, fetch_mu, fetch_alpha, n12)
            R12s = ops.select(transmits, R12s, 1.0)
            T12s = 1.0 - R12s
            R12, T12 = RGB.splat(R12s), RGB.splat(T12s)
            R21, T21 = R12, T12
            dn = ops.abs(n12 - 1.0)
            s_t12 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=0.5 * dn / n12)
            s_t21 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=0.5 * dn)
            # Under TIR of the mean direction nothing reaches the layers below, so their spreads
            # are irrelevant: zero Jacobians restart the telescoping product n_i ct_i / ct_0 there
            # (with 1 it would gain a factor up to n / COS_FLOOR per TIR and overflow float32).
            j12 = ops.select(transmits, n12 * ctt / ops.max(cti, COS_FLOOR), 0.0)
            j21 = ops.select(transmits, ops.max(cti, COS_FLOOR) / (n12 * ops.max(ctt, COS_FLOOR)), 0.0)
        else:
            eta = p["eta"] / n_above
            k = p["k"] / n_above
            R12 = fgd_conductor(ops, fetch_mu, fetch_alpha, eta, k)
            T12 = T21 = R21 = RGB.splat(0.0)
            s_t12 = s_t21 = Spread.zero()
            j12 = j21 = 1.0
            ctt, tsx, tsy = cti, sx, sy

        # Belcour 2018's TIR correction (paper 001, after Eq. 10): of the light this interface
        # sends up, the part outside the escape cone is reflected back down by the stack above.
        # It corrects the stack-above statistics seen by *this* interface's lobe only; the
        # persisted statistics stay uncorrected so that the correction is not compounded at every
        # deeper interface (with compounding, inserting an index-matched coat changed the result).
        Ri0_seen, Ti0_seen = Ri0, Ti0
        if variant.tir and index > 0:
            spread_up = mapping.to_roughness(ops, (s_t0i + s_r12).mean())
            tir = tir_fraction(ops, sx, sy, n_above, spread_up)
            Ri0_seen = Ri0 + Ti0 * (1.0 - tir)
            Ti0_seen = Ti0 * tir
        m_R0i = T0i * R12 * Ti0_seen / (1.0 - Ri0_seen * R12).map(lambda d: ops.max(d, 1e-7))

        # Multiple scattering forms (Listing 3, lines 46-51)
        denom = (1.0 - Ri0 * R12).map(lambda d: ops.max(d, 1e-7))
        m_Ri0 = T21 * Ri0 * T12 / denom
        m_Rr = Ri0 * R12 / denom

        # Adding on energies (lines 53-57)
        e_R0i = R0i + m_R0i
        e_T0i = T0i * T12 / denom
        e_Ri0 = R21 + m_Ri0
        e_Ti0 = T21 * Ti0 / denom

        # Scalar forms (lines 59-66)
        r0i, e_r0i, e_ri0 = R0i.average(), e_R0i.average(), e_Ri0.average()
        m_r0i, m_ri0, m_rr, r21 = m_R0i.average(), m_Ri0.average(), m_Rr.average(), R21.average()

        # Adding on spreads (lines 68-76)
        bounce = (s_r12 + s_ri0).scale(m_rr)
        inner = s_t0i + s_r12 + bounce
        lobe_spread = s_ti0 + inner.scale(j0i)
        new_s_r0i = (s_r0i.scale(r0i) + lobe_spread.scale(m_r0i)).divide_safe(ops, e_r0i)
        new_s_t0i = s_t0i.scale(j12) + s_t12 + (s_r12 + s_ri0).scale(j12 * m_rr)
        new_s_ri0 = (s_r21.scale(r21)
                     + (s_t12 + (s_t21 + s_ri0 + bounce).scale(j12)).scale(m_ri0)).divide_safe(ops, e_ri0)
        new_s_ti0 = s_ti0 + s_t21.scale(ji0) + (s_r12 + s_ri0).scale(ji0 * m_rr)

        lax, lay, lrot = lobe_spread.to_lobe(ops, mapping)
        lobes.append(Lobe(m_R0i, lax, lay, lrot))

        R0i, T0i, Ri0, Ti0 = e_R0i, e_T0i, e_Ri0, e_Ti0
        s_r0i, s_t0i, s_ri0, s_ti0 = new_s_r0i, new_s_t0i, new_s_ri0, new_s_ti0
        j0i, ji0 = j0i * j12, ji0 * j21
        if kind == "base":
            break

        cti, sx, sy = ctt, tsx, tsy
        n_above = p["ior"]
        # The coat's interior: Beer-Lambert along the refracted mean direction
        if "sigma_a" in p:
            path = p["thickness"] / ops.max(cti, COS_FLOOR)
            t = p["sigma_a"].map(lambda s: ops.exp(-s * path))
            T0i, Ti0, Ri0 = T0i * t, Ti0 * t, Ri0 * t * t
    ops.set_scope("lobes")
    return lobes
