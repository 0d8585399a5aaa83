"""Stack presets and coat templates, as JSON (never Python): the built-in ones shipped in
``data/presets`` (listed, in menu order, with a description, by ``data/presets/INDEX.json``) and
the user's own, plain stack files in a folder the caller names (the extension's user folder).
"""
from __future__ import annotations

import json
import re
import uuid
from dataclasses import dataclass
from pathlib import Path

from .param_id import NORMAL
from .stack import Stack, StackError

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
PRESET_DIR = DATA_DIR / "presets"
TEMPLATES_FILE = DATA_DIR / "layer_templates.json"
USER_PREFIX = "user:"


@dataclass(frozen=True)
class Preset:
    """A preset: its stack file, and for a built-in one the procedural inputs it links into the
    material's Lamella node (``inputs``: socket name -> recipe name, e.g. ``{"coat0_coverage":
    "worn"}``; the recipes are node set-ups the Blender side builds, ``blender/input_recipes.py``)."""

    id: str  # "car_paint", or "user:<file stem>" for a user preset
    label: str
    description: str
    path: Path
    builtin: bool
    inputs: tuple = ()  # ((socket name, recipe name), ...)
    layer_labels: tuple = ()  # what the panel and the Lamella node call its coats, top to bottom (a built-in's)

    def load(self) -> Stack:
        try:
            return Stack.from_json(self.path.read_text())
        except OSError as e:
            raise StackError("stack", None, f"cannot read preset {self.label!r} ({self.path}): {e.strerror}") from None


def builtin() -> list[Preset]:
    index = json.loads((PRESET_DIR / "INDEX.json").read_text())
    return [Preset(p["id"], p["label"], p["description"], (PRESET_DIR / p["file"]).resolve(), True,
                   tuple(sorted(p.get("inputs", {}).items())), tuple(p.get("layers", ())))
            for p in index["presets"]]


def check_inputs(preset: Preset) -> None:
    """A ``StackError`` naming the preset and socket if an input it links is not a socket of its
    stack's layers (``coat<i>_<field>`` of an existing coat's kind, or ``base_<field>``), or naming
    the preset if a built-in one does not label each coat once, with labels of their own."""
    stack = preset.load()
    if preset.builtin and len(preset.layer_labels) != len(stack.coats):
        raise StackError("stack", None, f"preset {preset.id!r}: {len(preset.layer_labels)} layer labels for "
                                        f"{len(stack.coats)} coats")
    if len(set(preset.layer_labels)) != len(preset.layer_labels) or "Base" in preset.layer_labels:
        raise StackError("stack", None, f"preset {preset.id!r}: its layer labels must differ from each other and "
                                        f"from 'Base', got {list(preset.layer_labels)}")
    for socket, recipe in preset.inputs:
        layer, _, field = socket.partition("_")
        fields = {NORMAL}  # every layer has a Normal input of its own
        if layer == "base":
            kind = stack.base.kind
        elif layer.startswith("coat") and layer[4:].isdigit() and int(layer[4:]) < len(stack.coats):
            kind = stack.coats[int(layer[4:])].kind
        else:
            raise StackError("stack", None, f"preset {preset.id!r}: input {socket!r} names no layer of its stack")
        if field not in fields | {f.name for f in kind.fields}:
            raise StackError("stack", None, f"preset {preset.id!r}: input {socket!r}: a {kind.type} has no field "
                                            f"{field!r}")
        if not isinstance(recipe, str) or not recipe:
            raise StackError("stack", None, f"preset {preset.id!r}: input {socket!r} names no recipe")


MAX_PRESET_BYTES = 1_000_000  # a stack file is a few kB


def scan_user(folder: Path | None) -> tuple[list[Preset], list[tuple[Path, str]]]:
    """The user's presets in ``folder`` that load as stacks, and the files skipped, each with
    why: one bad file never hides the others (or the built-in presets)."""
    if folder is None or not Path(folder).is_dir():
        return [], []
    out, skipped = [], []
    for p in sorted(Path(folder).glob("*.json")):
        try:
            if p.stat().st_size > MAX_PRESET_BYTES:
                raise StackError("stack", None, f"{p.stat().st_size} bytes; a preset takes at most {MAX_PRESET_BYTES}")
            stack = Stack.from_json(p.read_text(encoding="utf-8"))
        except StackError as e:
            skipped.append((p, str(e)))
            continue
        except (OSError, ValueError) as e:
            skipped.append((p, f"cannot read it ({e})"))
            continue
        out.append(Preset(USER_PREFIX + p.stem, stack.name or p.stem, f"User preset ({p.name})", p, False))
    return out, skipped


def user(folder: Path | None) -> list[Preset]:
    """The user's presets in ``folder`` that load (``scan_user``)."""
    return scan_user(folder)[0]


def all_presets(user_folder: Path | None = None) -> list[Preset]:
    return builtin() + user(user_folder)


def find(preset_id: str, user_folder: Path | None = None) -> Preset:
    for p in all_presets(user_folder):
        if p.id == preset_id:
            return p
    raise KeyError(f"no preset {preset_id!r}")


def slug(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_-]+", "_", name.strip()).strip("_").lower()
    return s or "preset"


def save_user(folder: Path, name: str, stack: Stack) -> Path:
    """Write ``stack`` as user preset ``name`` (a JSON stack named ``name``); returns its path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    d = stack.to_dict()
    d["name"] = name
    path = folder / f"{slug(name)}.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(d, indent=2) + "\n")
    tmp.replace(path)
    return path


def layer_templates() -> list[dict]:
    """Coat templates of the panel's add menu: ``id``, ``label``, ``description``, ``icon`` and
    ``layer`` (a coat as in the stack description)."""
    return json.loads(TEMPLATES_FILE.read_text())["templates"]


# ---------------------------------------------------------------- asset catalogs
CATALOGS = {"presets": "Lamella/Presets", "paper": "Lamella/Paper Figures"}  # what the asset libraries show


def catalog_path(preset: Preset) -> str:
    """The asset catalog a built-in preset is listed under: the papers' figures, or the presets."""
    return CATALOGS["paper" if preset.id.startswith("paper_") else "presets"]


def catalog_id(path: str) -> str:
    """A fixed UUID per catalog path: every library built from the presets (the materials, the node
    groups) shares them, so Blender shows one tree of catalogs, and a rebuild is reproducible."""
    return str(uuid.uuid5(uuid.NAMESPACE_URL, f"lamella:{path}"))


def catalog_file(title: str) -> str:
    """The text of a ``blender_assets.cats.txt`` listing ``CATALOGS``, under a comment ``title``."""
    lines = [f"# {title}", "", "VERSION 1", ""]
    lines += [f"{catalog_id(path)}:{path}:{path.replace('/', '-')}" for path in CATALOGS.values()]
    return "\n".join(lines) + "\n"
