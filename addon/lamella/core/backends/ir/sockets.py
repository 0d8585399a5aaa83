"""The inputs a material shows: the model's parameters in the panel's units.

The traced model reads GGX alpha and one float per colour channel (``coat0_alpha``,
``base_eta_r``, ``base_eta_g``, ``base_eta_b``: ``layers.params``). A Script node's or node
group's sockets are where an artist links a texture, so they speak as the panel and Blender's
own BSDFs do:

- a roughness is Blender's r, alpha = r^2 (``coat0_roughness``, ``base_roughness_x``, ...);
- an RGB triple is one colour socket (``base_albedo``, ``coat0_sigma_a``, ``base_eta``);
- everything else keeps its name and unit (``coat0_ior``, ``coat0_thickness``, ``coat0_g``, and
  rotations in radians, Blender's angle unit).

Sockets are made from what each parameter is (``core.param_id.ParamId``: layer, field, channel,
unit), never from its name. Each emitter declares ``sockets(ids, values)`` and rebuilds a
parameter from its socket with ``Socket.convert`` (OSL: ``float coat0_alpha = coat0_roughness *
coat0_roughness;``; nodes: a Math or Separate Color node); a linked socket makes its parameters
live (``params_of``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from ...param_id import COLOUR_CHANNELS, ParamId, r_from_alpha, socket_name


@dataclass(frozen=True)
class Socket:
    """One input: ``name``; ``kind`` "float" or "color"; ``params``: the model parameters it
    feeds (one, or a colour's three channels in r, g, b order); ``convert``: "identity",
    "square" (roughness r to alpha) or "channels" (a colour's components); ``value``: its value
    in socket units (a float, or an RGB tuple); ``layer`` (coat index, None: the base), ``field``
    and ``axis`` ("x", "y" of an anisotropic roughness, else ""): what it is."""

    name: str
    kind: str
    params: tuple
    convert: str
    value: object
    layer: int | None = None
    field: str = ""
    axis: str = ""


def sockets(ids: Mapping[str, ParamId], values: Mapping[str, float] | None = None) -> list[Socket]:
    """The sockets of a model whose parameters are ``ids`` (name -> ``ParamId``), at ``values``
    (name -> model value; absent: 0), sorted by name."""
    values = values or {}
    colours: dict = {}
    out = []
    for name, pid in ids.items():
        v = float(values.get(name, 0.0))
        if pid.is_colour:
            colours.setdefault(pid.socket, {})[pid.channel] = (name, v, pid)
        elif pid.is_roughness:
            out.append(Socket(pid.socket, "float", (name,), "square", r_from_alpha(v), pid.layer, pid.field,
                              pid.channel))
        else:
            out.append(Socket(pid.socket, "float", (name,), "identity", v, pid.layer, pid.field, pid.channel))
    for sname, chans in colours.items():
        if set(chans) != set(COLOUR_CHANNELS):
            raise ValueError(f"{next(iter(chans.values()))[2].where}: a colour declares all three channels "
                             f"(declared: {', '.join(sorted(chans))})")
        parts = [chans[c] for c in COLOUR_CHANNELS]
        pid = parts[0][2]
        out.append(Socket(sname, "color", tuple(p[0] for p in parts), "channels", tuple(p[1] for p in parts),
                          pid.layer, pid.field, ""))
    return sorted(out, key=lambda s: s.name)


def by_param(ids: Mapping[str, ParamId]) -> dict:
    """Parameter name -> (its socket, the channel index or None)."""
    out = {}
    for s in sockets(ids):
        for k, p in enumerate(s.params):
            out[p] = (s, k if s.convert == "channels" else None)
    return out


def params_of(names, ids: Mapping[str, ParamId]) -> tuple:
    """The parameters fed by the sockets named ``names`` (names that are parameters themselves
    are accepted too, as a pipeline may name them); sorted."""
    table = {s.name: s.params for s in sockets(ids)}
    out = set()
    for n in names:
        if n in table:
            out.update(table[n])
        elif n in ids:
            out.add(n)
        else:
            raise KeyError(n)
    return tuple(sorted(out))


def socket_names(ids: Mapping[str, ParamId]) -> list[str]:
    return [s.name for s in sockets(ids)]


__all__ = ["Socket", "sockets", "by_param", "params_of", "socket_names", "socket_name"]
