"""The lobe kinds and each backend's table of them: every kind the core knows is printed by the OSL
backend and built by the node-graph backend, and neither backend knows a kind the core does not."""
from lamella.core import lobe_kinds
from lamella.core.backends.bsdf_nodes import BSDF_NODES, BsdfNode
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.backends.osl_closures import CLOSURES
from lamella.core.models.adding_doubling import Lobe
from lamella.core.models.rgb import RGB


def test_every_lobe_kind_has_its_osl_closure_and_its_blender_node():
    assert set(CLOSURES) == set(lobe_kinds.KINDS) == set(BSDF_NODES)


def test_each_backend_renders_each_kind_from_its_arguments():
    """The printer and the node builder take exactly the arguments the kind's ``args`` makes."""
    ops = NumpyOps()
    wi = (0.3, 0.1, (1.0 - 0.09 - 0.01) ** 0.5)
    lobe = Lobe(RGB.splat(0.5), 0.2, 0.1, 0.3, eta=1.4)
    for name, kind in lobe_kinds.KINDS.items():
        args = kind.args(ops, Lobe(lobe.weight, lobe.alpha_x, lobe.alpha_y, lobe.rotation, name, lobe.eta), wi)
        printed = CLOSURES[name]({k: f"a_{k}" for k in args})
        assert printed.endswith(")") and all(f"a_{k}" in printed for k in args), (name, printed)
        node = BSDF_NODES[name](ops, args, wi)
        assert isinstance(node, BsdfNode) and node.bl_idname.startswith("ShaderNodeBsdf"), name
