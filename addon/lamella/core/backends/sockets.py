"""The inputs a material shows: the model's parameters in the panel's units.

The traced model reads GGX alpha and one float per colour channel (``coat0_alpha``,
``base_eta_r``, ``base_eta_g``, ``base_eta_b``: ``layers.params``). A Script node's or node
group's sockets are where an artist links a texture, so they speak as the panel and Blender's
own BSDFs do:

- a roughness is Blender's r, alpha = r^2 (``coat0_roughness``, ``base_roughness_x``, ...);
- an RGB triple is one colour socket (``base_albedo``, ``coat0_sigma_a``, ``base_eta``);
- everything else keeps its name and unit (``coat0_ior``, ``coat0_thickness``, ``coat0_g``, and
  rotations in radians, Blender's angle unit).

Each emitter declares ``sockets(params)`` and rebuilds a parameter from its socket with
``Socket.convert`` (OSL: ``float coat0_alpha = coat0_roughness * coat0_roughness;``; nodes: a
Math or Separate Color node); a linked socket makes its parameters live (``params_of``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

CHANNELS = ("r", "g", "b")


@dataclass(frozen=True)
class Socket:
    """One input: ``name``; ``kind`` "float" or "color"; ``params``: the model parameters it
    feeds (one, or a colour's three channels); ``convert``: "identity", "square" (roughness r to
    alpha) or "channels" (a colour's components); ``value``: its value in socket units (a float, or
    an RGB tuple)."""

    name: str
    kind: str
    params: tuple
    convert: str
    value: object


def _roughness_name(param: str) -> str | None:
    for suffix in ("_alpha", "_alpha_x", "_alpha_y"):
        if param.endswith(suffix):
            return param[: -len(suffix)] + suffix.replace("alpha", "roughness")
    return None


def sockets(params: dict) -> list[Socket]:
    """The sockets of a model whose parameters (name -> value) are ``params``, sorted by name."""
    out, done = [], set()
    for name in sorted(params):
        if name in done:
            continue
        rough = _roughness_name(name)
        stem, _, ch = name.rpartition("_")
        triple = tuple(f"{stem}_{c}" for c in CHANNELS)
        if rough is not None:
            out.append(Socket(rough, "float", (name,), "square", math.sqrt(max(float(params[name]), 0.0))))
        elif ch in CHANNELS and all(p in params for p in triple):
            out.append(Socket(stem, "color", triple, "channels", tuple(float(params[p]) for p in triple)))
            done.update(triple)
        else:
            out.append(Socket(name, "float", (name,), "identity", float(params[name])))
    return sorted(out, key=lambda s: s.name)


def by_param(params: dict) -> dict:
    """Parameter name -> (its socket, the channel index or None)."""
    out = {}
    for s in sockets(params):
        for k, p in enumerate(s.params):
            out[p] = (s, k if s.convert == "channels" else None)
    return out


def params_of(names, params: dict) -> tuple:
    """The parameters fed by the sockets named ``names`` (names that are parameters themselves
    are accepted too, as a pipeline may name them); sorted."""
    table = {s.name: s.params for s in sockets(params)}
    out = set()
    for n in names:
        if n in table:
            out.update(table[n])
        elif n in params:
            out.add(n)
        else:
            raise KeyError(n)
    return tuple(sorted(out))


def socket_names(params: dict) -> list[str]:
    return [s.name for s in sockets(params)]


__all__ = ["Socket", "sockets", "by_param", "params_of", "socket_names"]
