"""Extensions written the way a new kind joins Lamella, one module each, for the contract tests
(``tests/unit/test_extension_contract.py``, ``tests/blender/test_extension_contract.py``): a
traced operation (``absorbance``), a coat kind that uses it (``tinted_lacquer``), a base kind
(``artist_metal``), a lobe kind (``translucent``), a model that emits it (``split_diffuse``) and a
benchmark (``coat_count``, ``lamella bench coat-count``). Each has ``register()`` and
``unregister()``; nothing registers on import, so the rest of the suite never sees them."""

from . import absorbance, artist_metal, coat_count, split_diffuse, tinted_lacquer, translucent

# in the order they register
MODULES = (absorbance, tinted_lacquer, artist_metal, translucent, split_diffuse, coat_count)


def register():
    for m in MODULES:
        m.register()


def unregister():
    for m in reversed(MODULES):
        m.unregister()
