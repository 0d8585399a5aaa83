"""Messages in the user's interface language, as Blender's own scripts and the Cycles add-on write
them: a message holding values is a template translated first and formatted after,
``iface_("Compiled ({model}, {ms:.0f} ms)").format(model=..., ms=...)``, and the label showing it
passes ``translate=False`` so Blender does not look the formatted text up again. A label of fixed
text is a plain literal (Blender translates it itself). Operator reports go through ``rpt_``.
Messages from the core (a stack error naming the layer and field) are shown as they are: the core
does not import bpy. ``tests/unit/test_messages_translatable.py`` holds the panel and the
operators to this."""
from __future__ import annotations

from bpy.app.translations import pgettext_iface as iface_
from bpy.app.translations import pgettext_rpt as rpt_

__all__ = ["iface_", "rpt_"]
