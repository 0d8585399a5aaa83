"""Brute-force image references: a stack built as explicit geometry in Cycles (issue 3).

The canonical sphere (radius 1) becomes the outermost interface; every further interface is a
concentric copy of the same mesh, ``SHELL_THICKNESS`` further in, down to the base:

    r_0 = 1            air -> coat 0          (dielectric_bsdf, coat 0's alphas and rotation)
    r_i = 1 - i d      coat i-1 -> coat i     (dielectric_bsdf, coat i's alphas and rotation)
    r_n = 1 - n d      coat n-1 -> base       (conductor_bsdf with exact complex Fresnel)

Each interface is shaded by ``osl/lamella_reference_interface.osl`` with the relative index of
refraction across it; Cycles path-traces every internal reflection (bounce limits raised to
``BOUNCES``), so the image is the stack's full multiple-scattering answer for the microfacet model
of ``lamella.core.reference`` -- no layer model involved.

Absorption: coat i with ``sigma_a`` and ``thickness`` t has normal optical depth sigma_a t. In a
shell of thickness d that is a homogeneous absorbing volume of density sigma_a t / d. Cycles sums
the volumes of nested closed meshes, so sphere i carries the *increase* of density over the coat
above it; a coat that absorbs less than the coat above it (in some channel) cannot be expressed
this way and is refused with a message naming the layer.

The shells are thin against the radius (d = 0.004, a quarter of a pixel at 128 px): light that
walks sideways inside a coat stays within the pixel it entered, as the BRDF (a local model)
assumes. ``lamella image-references --thickness`` re-renders with another d to check its effect.
"""
from __future__ import annotations

from ..core.backends.osl import OSL_DIR
from ..core.stack import Conductor, Stack

SHELL_THICKNESS = 0.004
BOUNCES = 64
SHADER_FILE = "lamella_reference_interface.osl"


def interface_radii(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[float]:
    """Radii of the interfaces, outermost first: one per coat plus the base."""
    n = len(stack.coats)
    if not (thickness > 0.0 and thickness * n < 0.5):
        raise ValueError(f"shell thickness {thickness} x {n} coats must stay inside half the sphere's radius")
    return [1.0 - i * thickness for i in range(n + 1)]


def absorption_densities(stack: Stack, thickness: float = SHELL_THICKNESS) -> list[tuple[float, float, float]]:
    """Per interface sphere (outermost first, the base excluded), the RGB absorption density it
    adds to the volumes of the spheres around it (Cycles sums nested volumes)."""
    out, above = [], (0.0, 0.0, 0.0)
    for i, c in enumerate(stack.coats):
        dens = tuple(s * c.thickness / thickness for s in c.sigma_a) if c.thickness > 0 else (0.0, 0.0, 0.0)
        step = tuple(d - a for d, a in zip(dens, above))
        if min(step) < -1e-12:
            raise ValueError(f"coat {i}: sigma_a * thickness {tuple(s * c.thickness for s in c.sigma_a)} is below "
                             "the coat above it in some channel; the nested-sphere reference can only add absorption "
                             "going inward")
        out.append(tuple(max(s, 0.0) for s in step))
        above = dens
    return out


def _interface_material(bpy, text, name: str, params: dict, volume_rgb=None):
    from .osl_compile import assign_script

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    node = nt.nodes.new("ShaderNodeScript")
    assign_script(node, text, (OSL_DIR / SHADER_FILE).read_text(), SHADER_FILE)
    for key, value in params.items():
        sock = node.inputs[key]
        sock.default_value = (*value, 1.0) if isinstance(value, tuple) and len(sock.default_value) == 4 else value
    nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    if volume_rgb is not None and max(volume_rgb) > 0.0:
        density = max(volume_rgb)
        vol = nt.nodes.new("ShaderNodeVolumeAbsorption")
        # Cycles' Volume Absorption: sigma_a = density * (1 - color)
        vol.inputs["Color"].default_value = (*(1.0 - s / density for s in volume_rgb), 1.0)
        vol.inputs["Density"].default_value = density
        nt.links.new(vol.outputs["Volume"], out.inputs["Volume"])
    return mat


def build_reference(sc, sphere, stack: Stack, thickness: float = SHELL_THICKNESS):
    """Turn the canonical scene's sphere into the nested-interface reference of ``stack``."""
    import bpy

    if not isinstance(stack.base, Conductor):
        raise ValueError(f"the nested-sphere reference does not build {stack.base.type} bases yet")
    for i, c in enumerate(stack.coats):
        if c.has_scattering:
            raise ValueError(f"coat {i}: sigma_s > 0 (a scattering medium); the nested-sphere reference does "
                             "not build scattering volumes yet")
    radii = interface_radii(stack, thickness)
    volumes = absorption_densities(stack, thickness)
    text = bpy.data.texts.new(SHADER_FILE)

    c = sc.cycles
    c.max_bounces = c.glossy_bounces = c.transmission_bounces = BOUNCES
    c.transparent_max_bounces = BOUNCES
    c.diffuse_bounces = 0
    c.volume_bounces = 0
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
            params = {"eta": coat.ior / n_above, "alpha_x": coat.roughness[0], "alpha_y": coat.roughness[1],
                      "rotation": coat.rotation, "conductor": 0}
            mat = _interface_material(bpy, text, f"interface_{i}", params, volumes[i])
            n_above = coat.ior
        else:
            b = stack.base
            params = {"alpha_x": b.roughness[0], "alpha_y": b.roughness[1], "rotation": b.rotation, "conductor": 1,
                      "conductor_eta": tuple(e / n_above for e in b.eta),
                      "conductor_k": tuple(k / n_above for k in b.k)}
            mat = _interface_material(bpy, text, "base", params)
        obj.data.materials.append(mat)
    return radii

