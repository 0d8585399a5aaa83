"""Keeping a material's shader in step with its stack.

An edit (any property update) only *schedules* work: the material goes into a pending set and one
``bpy.app.timers`` callback compiles it once edits have paused for ``DEBOUNCE`` seconds, outside
any draw or update callback. Blender run as a module or with ``-b`` has no event loop, so timers
never fire there: pending work is also flushed before every render and every save (handlers), and
``flush()`` does it on demand.

The node group (EEVEE, Cycles without OSL) of a stack with many coats takes seconds to build
(``bench/recompile.md``), ten times the OSL compile. A structure edit of a material whose OSL
shader renders in Cycles therefore updates the Script node at once and builds the group only when
something renders it: at once if a scene needs it (EEVEE, or Cycles without OSL:
``material_nodes.group_needed``), else after ``GROUP_DELAY`` seconds without edits (the viewport's
Material Preview runs EEVEE), before a render that needs it, before a save, and when a scene
switches to an engine that needs it. A material whose shader leaves the Script node out (a linked
input reaching a table file: ``material_nodes.install``) builds its group at once. The layer
operators (add, remove, duplicate, move) do the same; ``apply_stack`` and the Recompile operator
build both at once. None of this runs at render time for the render's sake: the saved file
renders right without the extension (the face's engine switch, ``face``).

A slider dragged sends an edit every few tens of milliseconds. An edit the edit timer compiles
within ``DRAG_WINDOW`` of the material's previous compile keeps that compile's grouping of the
lobes into closures (``lobe_budget.merge``'s ``partition``: the energies and roughnesses merged
anew, the automatic budget's search skipped, about half the staging time of eight coats with
media); once edits pause for ``SETTLE_DELAY``, and before every render and save, such a
material is compiled again with its lobes merged anew (``settle``), so what renders and what is
saved never depends on the drag.

A compile validates the stack, traces and compiles the shader, and only then touches the
material. A stack that fails (a forced model that cannot run it, a compile error) leaves the last
working shader in place and puts the message, which names the layer and field, in the status.
"""
from __future__ import annotations

import sys
import time
import traceback
from contextlib import contextmanager

import bpy
from bpy.app.handlers import persistent

from ..core import stack_format
from ..core.backends.ir.staging import NotAnInput
from ..core.backends.osl.emit import osl_shader
from ..core.models import UnsupportedStack
from ..core.stack import Stack, StackError
from . import app_handlers, compiled, input_recipes, inspector, material_nodes, socket_edits, versioning
from .animation import mirror_panel
from .material_nodes import group_needed, osl_usable
from .osl_compile import OSLCompileError, compile_source
from .stack_props import ensure_labels, ensure_uids, stack_dict

DEBOUNCE = 0.08  # seconds of quiet after an edit before the shader is rebuilt
GROUP_DELAY = 0.5  # seconds of quiet after an edit before a node group nobody renders is rebuilt
DRAG_WINDOW = 0.5  # seconds: an edit compiled this soon after the material's last compile continues a drag
SETTLE_DELAY = 0.3  # seconds of quiet after a drag before its materials' lobes are merged anew

_pending: dict[str, bool] = {}  # material name_full -> whether its shader must be rebuilt
_stale_groups: set[str] = set()  # materials whose node group waits for a rebuild
_last_compile: dict[str, tuple] = {}  # material name_full -> (when, its lobes' grouping) of its last compile
_unsettled: set[str] = set()  # materials compiled with a drag's kept grouping (``settle`` merges anew)
_last_edit = 0.0
_suspended = 0


@contextmanager
def suspended():
    """Property writes inside this block schedule nothing (bulk writes compile once, after)."""
    global _suspended
    _suspended += 1
    try:
        yield
    finally:
        _suspended -= 1


def _report(mat, what: str, error: Exception) -> None:
    """A failure while handling one material: its status says what failed (the material keeps
    what it had), the traceback goes to the console, and the caller goes on with the next
    material. Handlers never raise: one broken material must not cost another one its edits."""
    print(f"Lamella: {what} of material {getattr(mat, 'name', '?')!r} failed:", file=sys.stderr)
    traceback.print_exception(error, file=sys.stderr)
    try:
        mat.lamella.status = "ERROR"
        mat.lamella.status_message = f"{what} failed ({type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''})"
    except Exception:  # noqa: BLE001 - a material that cannot even take its status
        pass


def _guarded(mat, what: str, fn, default=None):
    """``fn()``, or ``default`` after ``_report`` if it raises."""
    try:
        return fn()
    except Exception as e:  # noqa: BLE001 - see _report
        _report(mat, what, e)
        return default


def _material(key: str):
    return next((m for m in bpy.data.materials if m.name_full == key), None)


def _queue(mat, shader: bool) -> None:
    global _last_edit
    if _suspended or mat is None or not isinstance(mat, bpy.types.Material) or not mat.lamella.enabled:
        return
    key = mat.name_full
    _pending[key] = _pending.get(key, False) or shader
    _last_edit = time.perf_counter()
    if not bpy.app.timers.is_registered(_on_timer):
        bpy.app.timers.register(_on_timer, first_interval=DEBOUNCE)


def schedule(mat) -> None:
    """Rebuild ``mat``'s shader soon (debounced)."""
    if not _suspended and mat is not None and getattr(mat, "library", None) is None and mat.lamella.enabled:
        mat.lamella.status = "PENDING"
    _queue(mat, True)


def never_compiled(mat) -> bool:
    """A Lamella material that holds a stack but no shader yet (an asset appended from the
    preset library, a material made by a script that set its properties): compiled when it first
    appears in a scene or before a render."""
    s = mat.lamella
    return mat.library is None and s.enabled and not s.compiled_json and s.status == "NONE"


def schedule_inspector(mat) -> None:
    """Refresh ``mat``'s lobe inspector soon (debounced)."""
    _queue(mat, False)


def pending() -> list[str]:
    return list(_pending)


def _on_timer():
    wait = DEBOUNCE - (time.perf_counter() - _last_edit)
    if wait > 1e-3:
        return wait
    flush(defer_inspector=True, drag=True)
    return DEBOUNCE if _pending else None  # the lobe inspectors, on the next tick


def flush(defer_inspector: bool = False, drag: bool = False) -> None:
    """Do all pending work now; a node group no scene renders now waits (``flush_groups``). With
    ``defer_inspector`` (the edit timer) the lobe inspectors of recompiled materials are only
    scheduled: the material updates first, the panel's preview a tick later. With ``drag`` (the
    edit timer) a material compiled within ``DRAG_WINDOW`` keeps its lobes' grouping until
    ``settle``."""
    work = dict(_pending)
    _pending.clear()
    for key, shader in work.items():
        mat = _material(key)
        if mat is None or not mat.lamella.enabled:
            continue
        if shader:
            done = _guarded(mat, "compiling the shader", lambda m=mat: compile_material(
                m, defer_group=not groups_needed(), inspect=not defer_inspector, drag=drag), False)
            if done and defer_inspector:
                schedule_inspector(mat)
        else:
            _guarded(mat, "the lobe inspector", lambda m=mat: inspector.update(m))


def settle() -> None:
    """Compile every material a drag left with its kept grouping (``_unsettled``) with its lobes
    merged anew, as any other compile does."""
    work = sorted(_unsettled)
    _unsettled.clear()
    for key in work:
        mat = _material(key)
        if mat is not None and mat.lamella.enabled and not _pending.get(key):  # a pending compile settles it
            _guarded(mat, "compiling the shader", lambda m=mat: compile_material(m, defer_group=not groups_needed()))


def _on_settle_timer():
    wait = SETTLE_DELAY - (time.perf_counter() - _last_edit)
    if _pending or wait > 1e-3:
        return max(wait, DEBOUNCE)
    settle()
    return None


def groups_needed() -> bool:
    """Whether a scene of the file renders Lamella materials through the node group now."""
    return any(group_needed(sc) for sc in bpy.data.scenes)


def stale_groups() -> list[str]:
    """The materials whose node group waits for a rebuild."""
    return sorted(_stale_groups)


def flush_groups() -> None:
    """Build every node group that waits, from the stack and shader the material shows."""
    work = sorted(_stale_groups)
    _stale_groups.clear()

    def build(mat):
        shown = compiled.get(mat)
        material_nodes.build_group(mat, shown.stack, mat.lamella.model, (shown.live, mat.lamella.lobe_budget))

    for key in work:
        mat = _material(key)
        if mat is None or material_nodes.face_node(mat) is None or not mat.lamella.enabled \
                or not mat.lamella.compiled_json:
            continue
        _guarded(mat, "building the node group", lambda m=mat: build(m))
    if work:
        _guarded(None, "removing unused data", material_nodes.drop_unused_data)


def _on_group_timer():
    wait = GROUP_DELAY - (time.perf_counter() - _last_edit)
    if _pending or wait > 1e-3:
        return max(wait, DEBOUNCE)
    flush_groups()
    return None


def build_shader(stack, model: str, live=(), budget="auto", partition=None):
    """Stage and compile the shader of ``stack`` under ``model`` without touching any material,
    with the parameters ``live`` read from their sockets and every other value baked, lobes
    merged to ``budget`` (or grouped as ``partition``, where it fits: ``lobe_budget.merge``):
    (OslShader, .oso path, the model that ran). Raises StackError, UnsupportedStack, ValueError
    (an unknown model) or OSLCompileError."""
    shader = osl_shader(stack, model, live=live, budget=budget, partition=partition, engine_switch=True,
                        tables="inline")
    return shader, compile_source(shader.source, "lamella"), shader.model


def install(mat, stack, built, t0: float | None = None, defer_group: bool = False, inspect: bool = True) -> None:
    """Put a built shader into ``mat`` and record what it shows. With ``defer_group`` a structure
    change leaves the node group for ``flush_groups`` (a timer, a render or a save); without
    ``inspect`` the lobe inspector is left for the caller to refresh."""
    shader, oso, picked = built
    if material_nodes.install(mat, stack, mat.lamella.model, shader, oso, build_group=not defer_group) is None:
        _stale_groups.add(mat.name_full)
        if not bpy.app.timers.is_registered(_on_group_timer):
            bpy.app.timers.register(_on_group_timer, first_interval=GROUP_DELAY)
    else:
        _stale_groups.discard(mat.name_full)
    settings = mat.lamella
    settings.picked_model = picked
    if shader.staged is not None:
        settings.closures = len(shader.staged.closures)
        settings.lobes_all = shader.staged.lobes_all
    settings.live_params = ", ".join(shader.live_sockets)
    settings.compiled_json = stack.to_json(indent=None)
    compiled.record(mat, stack, script=material_nodes.inner_nodes(mat)[1] is not None)
    settings.format = stack_format.FORMAT  # compiled from properties of this Lamella's schema
    settings.status = "OK"
    settings.status_message = ""
    if t0 is not None:
        settings.compile_ms = (time.perf_counter() - t0) * 1e3
    if inspect:
        inspector.update(mat)


def compile_material(mat, raise_errors: bool = False, defer_group: bool = False, inspect: bool = True,
                     drag: bool = False) -> bool:
    """Rebuild ``mat``'s shader from the stack its properties hold, under its model setting (and
    its node group, unless ``defer_group``; its lobe inspector unless not ``inspect``: see
    ``install``). With ``drag``, a compile within ``DRAG_WINDOW`` of the last keeps its grouping
    of the lobes (module docstring). On failure the status says why and
    the material keeps its shader (with ``raise_errors`` the error is raised too). Returns whether
    it compiled."""
    settings = mat.lamella
    t0 = time.perf_counter()
    ensure_uids(settings)
    ensure_labels(settings)
    if not versioning.refuses_edits(settings):
        with suspended():  # a value typed on the node: this compile takes it
            _guarded(mat, "reading the values typed on the node", lambda: socket_edits.take(mat))
        input_recipes.link_pending(mat)  # a preset's procedural inputs, waiting for the Lamella node
        material_nodes.sync_inputs(mat)  # what is linked or animated, by layer, before the live set is read
    if settings.compiled_json:
        _guarded(mat, "checking the nodes", lambda: repair_needed(mat))
    if versioning.refuses_edits(settings):  # a newer Lamella's data: keep it and its shader as saved
        settings.status = "ERROR"
        settings.status_message = versioning.newer_message(versioning.stored_format(settings))
        if raise_errors:
            raise StackError("stack", "format", settings.status_message)
        return False
    key = mat.name_full
    last = _last_compile.get(key)
    partition = last[1] if drag and last is not None and t0 - last[0] < DRAG_WINDOW else None
    try:
        stack = Stack.from_dict(stack_dict(settings))
        built = build_shader(stack, settings.model, material_nodes.linked_sockets(mat), settings.lobe_budget,
                             partition)
    except (StackError, UnsupportedStack, OSLCompileError, ValueError) as e:
        settings.status = "ERROR"
        settings.status_message = (material_nodes.not_an_input_message(mat, e.names) if isinstance(e, NotAnInput)
                                   else str(e) if isinstance(e, OSLCompileError) else str(e).splitlines()[0])
        if raise_errors:
            raise
        return False
    except Exception as e:  # noqa: BLE001 - a defect: nothing was touched, the material keeps its shader
        if raise_errors:
            raise
        _report(mat, "compiling the shader", e)
        return False
    install(mat, stack, built, t0, defer_group, inspect)
    merged = built[0].staged.merged if built[0].staged is not None else None
    _last_compile[key] = (time.perf_counter(), merged)
    if partition is not None and merged == partition:  # kept, not searched: merged anew once edits pause
        _unsettled.add(key)
        if not bpy.app.timers.is_registered(_on_settle_timer):
            bpy.app.timers.register(_on_settle_timer, first_interval=SETTLE_DELAY)
    else:
        _unsettled.discard(key)
    material_nodes.drop_unused_data()
    return True


def check_nodes(mat) -> str | None:
    """What is broken in ``mat``'s nodes (``material_nodes.broken``; a node group that waits for
    its rebuild is not), or None; recorded for the panel (``compiled.note_nodes``), which shows it
    without checking anything itself."""
    why = material_nodes.broken(mat, group_pending=mat.name_full in _stale_groups)
    compiled.note_nodes(mat, why, material_nodes.inner_nodes(mat)[1] is not None)
    return why


_to_check: set[int] = set()  # session_uid of the materials whose nodes the panel wants checked


def check_soon(mat) -> None:
    """Check ``mat``'s nodes on the next tick (``check_nodes``): the panel asks for it where what
    it shows is stale (``compiled.stale``), and never checks in its draw code."""
    _to_check.add(mat.session_uid)
    if not bpy.app.timers.is_registered(_on_check_timer):
        bpy.app.timers.register(_on_check_timer, first_interval=0.0)


def _on_check_timer():
    work = set(_to_check)
    _to_check.clear()
    changed = False
    for mat in bpy.data.materials:
        if mat.session_uid in work and mat.lamella.enabled and mat.lamella.compiled_json:
            before = compiled.shown_nodes(mat)
            _guarded(mat, "checking the nodes", lambda m=mat: check_nodes(m))
            changed |= compiled.shown_nodes(mat) != before
    if changed:
        _redraw_panels()
    return None


def _redraw_panels() -> None:
    """Redraw the editors that show the Lamella panel (Properties, the shader editor's sidebar)."""
    wm = getattr(bpy.context, "window_manager", None)
    for window in (wm.windows if wm is not None else ()):
        for area in window.screen.areas:
            if area.type in ("PROPERTIES", "NODE_EDITOR"):
                area.tag_redraw()


def repair_needed(mat) -> str | None:
    """What is broken in ``mat``'s nodes (``check_nodes``), after preparing the rebuild that
    repairs it; None if nothing is."""
    why = check_nodes(mat)
    if why:
        material_nodes.prepare_repair(mat)
    return why


def links_changed(mat) -> bool:
    """Whether the sockets linked in ``mat`` differ from those its shader reads live (a
    texture linked or unlinked since the last compile: a structure edit)."""
    s = mat.lamella
    return bool(s.enabled and s.compiled_json) and material_nodes.linked_sockets(mat) != compiled.get(mat).live


# ---------------------------------------------------------------- handlers
@persistent
def _flush_before(*_args):
    """Before a save: every pending shader and node group, so the file holds both up to date (and
    a drag's materials merged anew: ``settle``), the values typed on the Lamella nodes taken into
    their panels (``socket_edits``) and the panel's animation copied onto the Lamella nodes
    (``animation``), so the file renders it without the extension."""
    _take_typed_values()
    for mat in _mirror_animation():
        if mat.name_full not in _pending and _guarded(mat, "reading the links", lambda m=mat: links_changed(m), False):
            _pending[mat.name_full] = True
    if _pending:
        flush()
    if _unsettled:
        settle()
    if _stale_groups:
        flush_groups()


def _mirror_animation() -> list:
    """Copy every Lamella material's panel animation onto its Lamella node again (keys may have
    been edited since); returns the materials that have any."""
    out = []
    for mat in bpy.data.materials:
        if mat.library is None and mat.lamella.enabled and mat.lamella.compiled_json and mat.animation_data is not None:
            _guarded(mat, "copying the panel's animation", lambda m=mat: mirror_panel(m))
            out.append(mat)
    return out


_osl_state: dict[str, tuple] = {}  # scene name -> (engine, whether its Cycles ran OSL) at the last look


def _take_typed_values(trees=None) -> None:
    """The values typed on Lamella nodes into their panels (``socket_edits.take``, which schedules
    their compiles), for every material, or those whose node tree is in ``trees`` (pointers)."""
    for mat in bpy.data.materials:
        if mat.library is None and mat.lamella.enabled and mat.lamella.compiled_json and (
                trees is None or (mat.node_tree is not None and mat.node_tree.as_pointer() in trees)):
            _guarded(mat, "reading the values typed on the node", lambda m=mat: socket_edits.take(m))


@persistent
def _before_render(scene, *_args):
    _take_typed_values()
    _mirror_animation()
    for mat in bpy.data.materials:  # a texture linked or unlinked since the last compile, or a node broken
        if never_compiled(mat):
            _pending[mat.name_full] = True
        elif mat.library is None and mat.lamella.enabled and mat.lamella.compiled_json:
            if _guarded(mat, "reading the links", lambda m=mat: links_changed(m), False):
                _pending[mat.name_full] = True
            elif mat.name_full not in _pending and _guarded(mat, "checking the nodes", lambda m=mat: repair_needed(m)):
                _pending[mat.name_full] = True
    if _pending:
        flush()
    if _unsettled:
        settle()
    if _stale_groups and _guarded(scene, "checking the engine", lambda: group_needed(scene), True):
        flush_groups()


@persistent
def _after_depsgraph(scene, depsgraph=None, *_args):
    """When the scene's engine, OSL switch or device changes, build the node groups that wait if
    the scene now renders them (cheap otherwise: one comparison); take a value typed on a Lamella
    node into its panel (``socket_edits``: looked for in the updated node trees only); compile a Lamella
    material that arrives without a shader (``never_compiled``: looked for among the updated data
    only)."""
    if depsgraph is not None:
        trees = set()
        for update in depsgraph.updates:
            mat = update.id.original
            if isinstance(mat, bpy.types.Material) and never_compiled(mat):
                schedule(mat)
            elif isinstance(mat, bpy.types.ShaderNodeTree):  # a material's nodes: a value typed on one?
                trees.add(mat.as_pointer())
        if trees:
            _take_typed_values(trees)

    state = (scene.render.engine, osl_usable(scene))
    if _osl_state.get(scene.name) != state:
        _osl_state[scene.name] = state
        if _stale_groups and group_needed(scene):
            flush_groups()


@persistent
def _after_load(*_args):
    """A .blend opened: its materials brought to this version (``versioning``: the stack format,
    the layers' identities, an earlier version's nodes moved into the face); the lobe inspectors'
    previews redrawn (images are not saved with their pixels)."""
    _pending.clear()
    _stale_groups.clear()
    _unsettled.clear()
    _last_compile.clear()
    for mat in bpy.data.materials:
        if mat.library is None and mat.lamella.enabled:
            state = _guarded(mat, "reading the stored stack", lambda m=mat: versioning.check_loaded(m), "current")
            if state == "newer":
                continue
            if state == "migrated" or _guarded(mat, "reading the nodes", lambda m=mat: material_nodes.old_layout(m)):
                schedule(mat)
            schedule_inspector(mat)
    _guarded(None, "removing unused data", material_nodes.drop_unused_data)


_HANDLERS = (("render_pre", _before_render), ("save_pre", _flush_before), ("load_post", _after_load),
             ("depsgraph_update_post", _after_depsgraph))


def register():
    app_handlers.add(_HANDLERS)


def unregister():
    app_handlers.remove(_HANDLERS)
    for timer in (_on_timer, _on_group_timer, _on_settle_timer, _on_check_timer):
        if bpy.app.timers.is_registered(timer):
            bpy.app.timers.unregister(timer)
    _pending.clear()
    _stale_groups.clear()
    _unsettled.clear()
    _last_compile.clear()
    _to_check.clear()
