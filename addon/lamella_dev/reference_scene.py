"""Brute-force image references: a stack built as explicit geometry in Cycles.

The canonical sphere (radius 1) becomes the outermost interface; every further interface is a
concentric copy of the same mesh, ``SHELL_THICKNESS`` further in, down to the base:

    r_0 = 1            air -> coat 0          (dielectric_bsdf, coat 0's alphas and rotation)
    r_i = 1 - i d      coat i-1 -> coat i     (dielectric_bsdf, coat i's alphas and rotation)
    r_n = 1 - n d      coat n-1 -> base       (the core: see "Bases" below)

Each interface is shaded by ``data/osl/lamella_reference_interface.osl`` with the relative index of
refraction across it; Cycles path-traces every internal reflection (bounce limits raised to
``BOUNCES``), so the image is the stack's full multiple-scattering answer for the microfacet model
of ``lamella_dev.reference`` -- no layer model involved. An index-matched smooth interface (a
pure medium: ior equal to the medium above, roughness 0, such as dust or fog) is a Transparent
BSDF instead: it only marks where the medium begins, bends and reflects nothing, and lets shadow
rays through. (A smooth dielectric_bsdf at eta = 1 is not invisible in Cycles: measured -0.4 % with
outliers under the forest HDRI, and as a delta interface it hides a sun from everything below it.)

Bases (the core sphere of radius r_n):
* ``conductor``: conductor_bsdf with exact complex Fresnel, (eta + i k) / n of the coat above.
* ``diffuse``: Cycles' Diffuse BSDF (Lambertian, roughness 0) with the base's albedo.
* ``dielectric``: the same rough dielectric interface as a coat, relative index
  base.ior / n of the coat above. The core is a *solid ball* of that glass below its coats: light
  that refracts into the base crosses the ball and leaves it through its back, then through the
  coats on the far side of the sphere, into the scene. A pixel therefore shows the stack's
  reflection plus light transmitted through the whole sphere from behind (not the stack's
  reflectance alone; under the white furnace a lossless glass stack renders 1). The glass itself
  is clear, which the nested volumes (below) can only give when the coat directly above the base
  has no medium: other stacks are refused, naming that coat.

Media: coat i with ``thickness`` t, ``sigma_a``, ``sigma_s`` and Henyey-Greenstein ``g``
(Henyey and Greenstein 1941) fills its shell of thickness d with a homogeneous volume of
absorption density sigma_a t / d and scattering density sigma_s t / d (Cycles' Volume
Coefficients node, phase Henyey-Greenstein, anisotropy g). The shell is thinner than the coat by
t / d and denser by d / t, so the optical depth along the normal, sigma t, is preserved (and along
any direction in the planar limit, the path lengths scaling alike); what changes is only how far
light walks sideways in the medium, which the BRDF, a local model, does not see either.

Cycles sums the volumes of all the closed meshes a point lies in, so sphere i carries the
*increase* of the coat's volume over the coat above it. Absorption that decreases going inward
cannot be written this way and is refused with a message naming the coat. Scattering is a sum of
phase functions weighted by their densities: an increase of scattering with the same g keeps the
Henyey-Greenstein shape, but nothing subtracts the scattering of a coat from the shells below it.
So a scattering coat must be the lowest coat (above an opaque base), or every coat below it must
scatter with the same g and at least its density (identical media are the common case); otherwise
the stack is refused with a message naming the scattering coat.

Cycles settings: every bounce limit (total, diffuse, glossy, transmission, volume, transparent) is
``BOUNCES``, or ``MEDIUM_BOUNCES`` when a coat scatters (the number of events
``lamella_dev.reference`` walks): in the white furnace a lossless medium of normal optical depth
4 (g = 0.7) over a mirror renders 0.981-0.988 with 64 bounces and 0.999-1.000 with 256.
The media have constant coefficients (no texture or attribute input), so Cycles 5.0 takes its
homogeneous-volume path (no SD_HETEROGENEOUS_VOLUME flag): one shader evaluation per segment,
analytic transmittance and analytic exponential distance sampling; the ray-marching step rate and
max steps play no part (the default integrator is null-scattering, and even the biased ray marcher
takes one step through a homogeneous volume). Distance sampling is selected for the media (all
lights of the canonical scenes are at infinity, where equiangular sampling does not apply).

The shells are thin against the radius (d = 0.004, a quarter of a pixel at 128 px): light that
walks sideways inside a coat stays within the pixel it entered, as the BRDF (a local model)
assumes. ``lamella image-references --thickness`` re-renders with another d to check its effect.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from lamella.core.stack import Stack

SHELL_THICKNESS = 0.004
BOUNCES = 64
MEDIUM_BOUNCES = 256  # every bounce limit when a coat scatters
SHADER_FILE = "lamella_reference_interface.osl"
SHADER_DIR = Path(__file__).resolve().parent / "data" / "osl"
BASE_TYPES = ("conductor", "diffuse", "dielectric")
MATCHED_ETA = 1e-9  # |eta_rel - 1| below this (and roughness 0): an invisible, Transparent boundary

RGB = tuple[float, float, float]
_ZERO = (0.0, 0.0, 0.0)


class ShellVolume(NamedTuple):
    """The homogeneous volume one interface sphere adds to those around it (Cycles sums them)."""

    sigma_a: RGB  # absorption density per unit length
    sigma_s: RGB  # scattering density per unit length
    g: float  # Henyey-Greenstein anisotropy of that scattering

    @property
    def empty(self) -> bool:
        return max(self.sigma_a) <= 0.0 and max(self.sigma_s) <= 0.0


def interface_radii(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[float]:
    """Radii of the interfaces, outermost first: one per coat plus the base."""
    n = len(stack.coats)
    if not (thickness > 0.0 and thickness * n < 0.5):
        raise ValueError(f"shell thickness {thickness} x {n} coats must stay inside half the sphere's radius")
    return [1.0 - i * thickness for i in range(n + 1)]


def _shell_density(coat, coefficients, thickness: float) -> RGB:
    """A coat's coefficients spread over a shell of ``thickness``: the normal optical depth kept."""
    if not coat.thickness > 0.0:
        return _ZERO
    return tuple(float(s) * coat.thickness / thickness for s in coefficients)


def _fmt(rgb) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in rgb) + ")"


def absorption_densities(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[RGB]:
    """Per interface sphere (outermost first, the base excluded), the RGB absorption density it
    adds to the volumes of the spheres around it (Cycles sums nested volumes)."""
    out, above = [], _ZERO
    for i, c in enumerate(stack.coats):
        dens = _shell_density(c, c.sigma_a, thickness)
        step = tuple(d - a for d, a in zip(dens, above))
        if min(step) < -1e-12:
            raise ValueError(f"coat {i}: sigma_a * thickness {tuple(s * c.thickness for s in c.sigma_a)} is below "
                             "the coat above it in some channel; the nested-sphere reference can only add absorption "
                             "going inward")
        out.append(tuple(max(s, 0.0) for s in step))
        above = dens
    return out


def scattering_densities(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[tuple[RGB, float]]:
    """Per interface sphere (outermost first, the base excluded), the RGB scattering density it
    adds to the spheres around it and the Henyey-Greenstein g of that scattering.

    Scattering from a coat fills every shell below it too; it is allowed there only where the
    lower coat scatters with the same g and at least the same density (the increase is then one
    more Henyey-Greenstein volume of that g). Otherwise: ValueError naming the scattering coat."""
    out: list[tuple[RGB, float]] = []
    above, g_above, source = _ZERO, 0.0, None  # source: the uppermost coat whose scattering is in `above`
    for i, c in enumerate(stack.coats):
        dens = _shell_density(c, c.sigma_s, thickness)
        if source is not None:
            tol = 1e-9 * max(above)
            lower = [k for k in range(3) if dens[k] < above[k] - tol]
            if c.g != g_above or lower:
                why = (f"scatters with g = {c.g:g}, not {g_above:g}" if c.g != g_above and max(dens) > 0.0
                       else "does not scatter" if max(dens) <= 0.0
                       else "scatters less in some channel")
                s = stack.coats[source]
                raise ValueError(
                    f"coat {source}: its scattering (sigma_s * thickness {_fmt(x * s.thickness for x in s.sigma_s)}, "
                    f"g = {s.g:g}) would fill the shell of coat {i} below it as well (Cycles sums the volumes of "
                    f"nested spheres), and coat {i} {why}: a scattering volume cannot be subtracted, so the "
                    "nested-sphere reference builds a scattering coat only as the lowest coat or above coats "
                    "that scatter with the same g and at least its density")
            step = tuple(max(d - a, 0.0) for d, a in zip(dens, above))
        else:
            step = dens
            if max(dens) > 0.0:
                source, g_above = i, c.g
        out.append((step, c.g if max(step) > 0.0 else 0.0))
        above = dens if source is not None else _ZERO
    return out


def shell_volumes(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[ShellVolume]:
    """Per coat sphere, outermost first: the volume it adds (absorption, scattering, g). Refuses
    (ValueError naming the layer) stacks whose media nested volumes cannot express, including a
    dielectric base under a coat with a medium (the glass ball would be filled with it)."""
    absorption = absorption_densities(stack, thickness)
    scattering = scattering_densities(stack, thickness)
    vols = [ShellVolume(a, s, g) for a, (s, g) in zip(absorption, scattering)]
    if stack.base.type == "dielectric" and stack.coats and not all(v.empty for v in vols):
        i = len(stack.coats) - 1
        raise ValueError(f"coat {i}: the dielectric base is a glass ball nested inside every coat's sphere, so "
                         f"Cycles would fill it with the media above it (coat {i}'s medium reaches down to the "
                         "base); the nested-sphere reference builds a glass base only under coats without a medium")
    return vols


def _script_node(bpy, nt, text, params: dict):
    from lamella.blender.osl_compile import assign_script

    node = nt.nodes.new("ShaderNodeScript")
    assign_script(node, text, (SHADER_DIR / SHADER_FILE).read_text(), SHADER_FILE)
    for key, value in params.items():
        sock = node.inputs[key]
        sock.default_value = (*value, 1.0) if isinstance(value, tuple) and len(sock.default_value) == 4 else value
    return node


def _interface_material(bpy, text, name: str, surface: str, params: dict, volume: ShellVolume | None = None,
                        normal=None):
    """A material for one interface sphere: ``surface`` is "script" (the OSL interface with
    ``params``), "transparent" (an invisible, index-matched boundary) or "diffuse" (``params``:
    albedo); ``volume`` the homogeneous medium this sphere adds; ``normal(node_tree)`` builds this
    interface's own shading normal (a bump) and returns its socket."""
    mat = bpy.data.materials.new(name)
    mat.cycles.volume_sampling = "DISTANCE"
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if surface == "script":
        node = _script_node(bpy, nt, text, params)
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    elif surface == "transparent":
        node = nt.nodes.new("ShaderNodeBsdfTransparent")
        node.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    elif surface == "diffuse":
        node = nt.nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = (*params["albedo"], 1.0)
        node.inputs["Roughness"].default_value = 0.0
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    else:
        raise ValueError(f"unknown interface surface {surface!r}")
    if normal is not None and surface != "transparent":
        nt.links.new(normal(nt), node.inputs["Normal"])
    if volume is not None and not volume.empty:
        # sigma_a and sigma_s per unit length, unscaled (mesh volumes ignore the object's scale)
        vol = nt.nodes.new("ShaderNodeVolumeCoefficients")
        vol.phase = "HENYEY_GREENSTEIN"
        vol.inputs["Absorption Coefficients"].default_value = volume.sigma_a
        vol.inputs["Scatter Coefficients"].default_value = volume.sigma_s
        vol.inputs["Anisotropy"].default_value = volume.g
        vol.inputs["Emission Coefficients"].default_value = _ZERO
        nt.links.new(vol.outputs["Volume"], out.inputs["Volume"])
    return mat


def _dielectric(eta: float, roughness, rotation: float, energy_conserving: int = 0) -> tuple[str, dict]:
    """The surface of a boundary of relative index ``eta``: an index-matched smooth boundary is
    Transparent (nothing to reflect or bend), anything else the OSL rough dielectric."""
    if abs(eta - 1.0) < MATCHED_ETA and roughness[0] == 0.0 and roughness[1] == 0.0:
        return "transparent", {}
    return "script", {"eta": eta, "alpha_x": roughness[0], "alpha_y": roughness[1], "rotation": rotation,
                      "conductor": 0, "energy_conserving": energy_conserving}


INTERFACES = ("single", "multiple")  # as lamella_dev.reference.INTERFACES


def build_reference(sc, sphere, stack: Stack, thickness: float = SHELL_THICKNESS, interfaces: str = "single",
                    normals=None):
    """Turn the canonical scene's sphere into the nested-interface reference of ``stack``. Its rough
    interfaces scatter once (``interfaces="single"``) or keep the energy their microsurface
    scatters again (``"multiple"``: Cycles' multiscatter GGX, see the interface shader).
    ``normals``: a shading normal of its own for some interfaces (``{"coat0": build, "base":
    build}``, ``build(node_tree)`` returning a normal socket, e.g. a bump): each shell is then a
    true layer with its own normal, the ground truth of a layer's Normal input (the shells are thin
    against the bump's scale, so the bump is local to its interface)."""
    normals = normals or {}
    for where, layer in [*((f"coat {i}", c) for i, c in enumerate(stack.coats)), ("base", stack.base)]:
        if getattr(layer, "film_thickness", 0.0) > 0.0:
            # measured in Blender 5.2: the OSL dielectric_bsdf with thinfilm_* keywords reflects a grey
            # 0.78 of the bare Fresnel factor at any thickness, no interference colour
            raise ValueError(f"{where}, field 'film_thickness': the nested spheres have no thin film (Cycles' OSL "
                             "MaterialX closures do not render one); the stochastic reference has it")
    import bpy

    if interfaces not in INTERFACES:
        raise ValueError(f"interfaces must be one of {', '.join(INTERFACES)}, got {interfaces!r}")
    ec = int(interfaces == "multiple")

    base = stack.base
    if base.type not in BASE_TYPES:
        raise ValueError(f"base: the nested-sphere reference does not build {base.type} bases")
    radii = interface_radii(stack, thickness)
    volumes = shell_volumes(stack, thickness)
    text = bpy.data.texts.new(SHADER_FILE)

    c = sc.cycles
    limit = MEDIUM_BOUNCES if any(max(v.sigma_s) > 0.0 for v in volumes) else BOUNCES
    c.max_bounces = c.glossy_bounces = c.transmission_bounces = limit
    c.diffuse_bounces = c.volume_bounces = c.transparent_max_bounces = limit
    c.caustics_reflective = c.caustics_refractive = True

    n_above = 1.0
    for i, r in enumerate(radii):
        if i == 0:
            obj = sphere
        else:
            obj = sphere.copy()
            obj.data = sphere.data.copy()
            obj.data.materials.clear()
            obj.scale = (r, r, r)
            sc.collection.objects.link(obj)
        obj.name = f"interface_{i}"
        if i < len(stack.coats):
            coat = stack.coats[i]
            surface, params = _dielectric(coat.ior / n_above, coat.roughness, coat.rotation, ec)
            mat = _interface_material(bpy, text, f"interface_{i}", surface, params, volumes[i],
                                      normals.get(f"coat{i}"))
            n_above = coat.ior
        elif base.type == "conductor":
            params = {"alpha_x": base.roughness[0], "alpha_y": base.roughness[1], "rotation": base.rotation,
                      "conductor": 1, "conductor_eta": tuple(e / n_above for e in base.eta),
                      "conductor_k": tuple(k / n_above for k in base.k), "energy_conserving": ec}
            mat = _interface_material(bpy, text, "base", "script", params, normal=normals.get("base"))
        elif base.type == "diffuse":
            mat = _interface_material(bpy, text, "base", "diffuse", {"albedo": tuple(base.albedo)},
                                      normal=normals.get("base"))
        else:
            surface, params = _dielectric(base.ior / n_above, base.roughness, base.rotation, ec)
            mat = _interface_material(bpy, text, "base", surface, params, normal=normals.get("base"))
        obj.data.materials.append(mat)
    return radii
