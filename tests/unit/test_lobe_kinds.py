"""The lobe kinds: each is one record (evaluated in numpy, printed in OSL, built from Blender nodes),
and the registry refuses a kind that lacks a part or reuses a name."""
import dataclasses

import pytest

from lamella.core import lobe_kinds
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.lobe_kinds import BsdfNode
from lamella.core.models.types import Lobe
from lamella.core.models.rgb import RGB


def test_the_registry_refuses_an_incomplete_or_clashing_kind():
    reflection = lobe_kinds.KINDS["reflection"]
    with pytest.raises(ValueError, match="registered already"):
        lobe_kinds.register(reflection)
    with pytest.raises(TypeError, match="lacks osl"):
        lobe_kinds.register(dataclasses.replace(reflection, name="no_printer", osl=None))
    with pytest.raises(ValueError, match="side"):
        lobe_kinds.register(dataclasses.replace(reflection, name="sideways", side="up"))
    assert "no_printer" not in lobe_kinds.KINDS and "sideways" not in lobe_kinds.KINDS


def test_each_backend_renders_each_kind_from_its_arguments():
    """The printer and the node builder take exactly the arguments the kind's ``args`` makes: an
    argument the OSL closure does not read is one its normaliser or the kind's own EEVEE node reads
    (``LobeKind.eevee``: moving it moves that node's inputs or weight)."""
    ops = NumpyOps()
    wi = (0.3, 0.1, (1.0 - 0.09 - 0.01) ** 0.5)
    lobe = Lobe(RGB.splat(0.5), 0.2, 0.1, 0.3, eta=1.4)
    for name, kind in lobe_kinds.KINDS.items():
        args = kind.args(ops, Lobe(lobe.weight, lobe.alpha_x, lobe.alpha_y, lobe.rotation, name, lobe.eta), wi)
        printed = kind.osl({k: f"a_{k}" for k in args})
        assert printed.endswith(")"), (name, printed)
        for k in args:
            if f"a_{k}" in printed:
                continue
            assert kind.eevee is not None, (name, k, printed)
            (node, f), other = kind.eevee(ops, args, wi), {**args, k: args[k] * 1.1 + 0.01}
            moved, g = kind.eevee(ops, other, wi)
            assert (any(node.floats[s] != moved.floats[s] for s in node.floats) or f != g
                    or kind.scale_of_args(ops, args, wi) != kind.scale_of_args(ops, other, wi)), (name, k)
        node = kind.node(ops, args, wi)
        assert isinstance(node, BsdfNode) and node.bl_idname.startswith("ShaderNodeBsdf"), name
