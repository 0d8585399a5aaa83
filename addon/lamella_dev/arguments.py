"""Argument types shared by the ``lamella`` command and the benches' own options.

Each is an argparse type (``Checked``): it converts the text of one option or refuses it with an
``ArgumentTypeError`` saying what is allowed, which argparse prefixes with the option's name
(``argument --res: must be ...``); the command prints that one line and exits with status 2
(``cli.Parser``). A type's ``kind`` and ``limits`` say what it accepts: the tests generate the
mistakes of every option from them (tests/unit/test_cli_mistakes.py).
"""
from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Callable, Iterable

SHOWN = 12  # names a message lists before it says how many more there are


class Checked:
    """An argparse type: ``convert(text)`` returns the value or raises ``ArgumentTypeError``.
    ``kind`` (e.g. ``"count"``) and ``limits`` (e.g. ``lo``, ``hi``, ``suffixes``) describe it."""

    def __init__(self, kind: str, convert: Callable[[str], object], **limits):
        self.kind, self.limits, self._convert = kind, limits, convert

    def __call__(self, text: str):
        return self._convert(text)

    def __repr__(self) -> str:
        return f"{self.kind}({', '.join(f'{k}={v!r}' for k, v in self.limits.items())})"


def _refuse(message: str) -> argparse.ArgumentTypeError:
    return argparse.ArgumentTypeError(message)


def listing(names: Iterable[str], shown: int = SHOWN) -> str:
    """``a, b, c`` or, past ``shown`` names, ``a, b, ... (N in all)``."""
    names = list(names)
    if len(names) <= shown:
        return ", ".join(names)
    return ", ".join(names[:shown]) + f", ... ({len(names)} in all)"


def close_names(name: str, names: Iterable[str]) -> list[str]:
    """The few names of ``names`` closest to ``name`` (difflib), best first."""
    return difflib.get_close_matches(name, list(names), n=3, cutoff=0.6)


def unknown(what: str, name: str, names: Iterable[str]) -> str:
    """``unknown <what> 'x' (did you mean 'y'?); one of: a, b, c``."""
    names = list(names)
    close = close_names(name, names)
    hint = f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
    return f"unknown {what} {name!r}{hint}; one of: {listing(names)}"


# ------------------------------------------------------------------ numbers
def count(hi: int | None = None, lo: int = 1) -> Checked:
    """A whole number from ``lo`` (1) to ``hi`` (no limit)."""
    def convert(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise _refuse(f"must be a whole number, got {text!r}") from None
        if n < lo or (hi is not None and n > hi):
            raise _refuse(f"must be a whole number from {lo} to {hi}, got {n}" if hi is not None
                          else f"must be a whole number, {lo} or more, got {n}")
        return n
    return Checked("count", convert, lo=lo, hi=hi)


def _finite(text: str) -> float | None:
    """The finite number ``text`` writes, else None."""
    try:
        x = float(text)
    except ValueError:
        return None
    return x if math.isfinite(x) else None


def number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> Checked:
    """A finite number in [lo, hi] (an end excluded where ``lo_open`` / ``hi_open``)."""
    allowed = f"a number {'above' if lo_open else 'from'} {lo:g} {'and below' if hi_open else 'to'} {hi:g}"

    def convert(text: str) -> float:
        x = _finite(text)
        if x is None or x < lo or x > hi or (lo_open and x == lo) or (hi_open and x == hi):
            raise _refuse(f"must be {allowed}, got {text!r}")
        return x
    return Checked("number", convert, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open)


def angle(lo: float, hi: float) -> Checked:
    """An angle in degrees from ``lo`` to ``hi``."""
    allowed = f"an angle in degrees from {lo:g} to {hi:g}"

    def convert(text: str) -> float:
        x = _finite(text)
        if x is None or not lo <= x <= hi:
            raise _refuse(f"must be {allowed}, got {text!r}")
        return x
    return Checked("angle", convert, lo=lo, hi=hi)


def angles(lo: float, hi: float, only: tuple[float, ...] | None = None) -> Checked:
    """Comma-separated angles in degrees from ``lo`` to ``hi`` (each one of ``only`` if given): a tuple."""
    allowed = (f"comma-separated angles in degrees, each one of {', '.join(f'{a:g}' for a in only)}" if only
               else f"comma-separated angles in degrees from {lo:g} to {hi:g}")

    def convert(text: str) -> tuple[float, ...]:
        out = tuple(_finite(item) for item in text.split(","))
        if any(x is None or not lo <= x <= hi or (only and x not in only) for x in out):
            raise _refuse(f"must be {allowed}, got {text!r}")
        return out
    return Checked("angles", convert, lo=lo, hi=hi, only=only)


def direction() -> Checked:
    """A vector ``x,y,z``: three finite numbers, not all zero (a tuple; not normalised)."""
    allowed = "three comma-separated finite numbers x,y,z, not all zero"

    def convert(text: str) -> tuple[float, float, float]:
        v = tuple(_finite(item) for item in text.split(","))
        if len(v) != 3 or None in v:
            raise _refuse(f"must be {allowed}, got {text!r}")
        if math.hypot(*v) == 0.0:
            raise _refuse(f"must be {allowed} (a direction needs a length), got {text!r}")
        return v
    return Checked("direction", convert)


# ------------------------------------------------------------------ names
def name(what: str, choices: Callable[[], Iterable[str]]) -> Checked:
    """One name of ``choices()`` (computed when the option is given: registries fill late)."""
    def convert(text: str) -> str:
        allowed = list(choices())
        if text not in allowed:
            raise _refuse(unknown(what, text, allowed))
        return text
    return Checked("name", convert, what=what, choices=choices)


def names(what: str, choices: Callable[[], Iterable[str]]) -> Checked:
    """Comma-separated names of ``choices()``: a list (empty items skipped, at least one name)."""
    def convert(text: str) -> list[str]:
        given = [n.strip() for n in text.split(",") if n.strip()]
        if not given:
            raise _refuse(f"must name at least one {what}, got {text!r}")
        allowed = list(choices())
        for n in given:
            if n not in allowed:
                raise _refuse(unknown(what, n, allowed))
        return given
    return Checked("names", convert, what=what, choices=choices)


IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def identifiers(what: str) -> Checked:
    """Comma-separated identifiers (letters, digits, ``_``): a list. Which exist is the command's
    to check (they depend on the stack)."""
    def convert(text: str) -> list[str]:
        given = [n.strip() for n in text.split(",") if n.strip()]
        bad = [n for n in given if not IDENTIFIER.fullmatch(n)]
        if not given or bad:
            raise _refuse(f"must be comma-separated {what} (letters, digits and _), got {text!r}")
        return given
    return Checked("identifiers", convert, what=what)


def text(what: str) -> Checked:
    """Free text of one line, not empty (e.g. a material's name)."""
    def convert(value: str) -> str:
        if not value.strip() or any(c in value for c in "\r\n\0"):
            raise _refuse(f"must be {what}: one line of text, not empty, got {value!r}")
        return value
    return Checked("text", convert, what=what)


def path_text(what: str) -> Checked:
    """A path written into an output as text (it need not exist here): one line, no ``"``."""
    def convert(value: str) -> str:
        if not value.strip() or any(c in value for c in '"\r\n\0'):
            raise _refuse(f"must be {what}: a path on one line without '\"', got {value!r}")
        return value
    return Checked("path_text", convert, what=what)


# ------------------------------------------------------------------ files
def _path(text: str) -> Path:
    if not text or "\0" in text:
        raise _refuse(f"must be a path, got {text!r}")
    return Path(text)


def _exists(p: Path) -> bool:
    try:
        return p.exists()
    except (OSError, ValueError):  # not a path at all (too long)
        return False


def _is_dir(p: Path) -> bool:
    try:
        return p.is_dir()
    except (OSError, ValueError):
        return False


def _check_creatable(path: Path, value: str) -> None:
    """Refuse ``value`` unless ``path`` exists as a folder or can be made: its nearest existing
    ancestor is a folder a file can be created in (tried with a temporary file, removed at once:
    permission bits do not stop root, and some file systems refuse whatever they say), and each
    name to create fits that file system."""
    folder = path
    while not _exists(folder) and folder != folder.parent:
        folder = folder.parent
    if not _is_dir(folder):
        raise _refuse(f"cannot be written: {str(folder)!r} is a file, not a folder, got {value!r}")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
        name_max, path_max = os.pathconf(folder, "PC_NAME_MAX"), os.pathconf(folder, "PC_PATH_MAX")
    except OSError as e:
        raise _refuse(f"cannot be written: no file can be created in {str(folder)!r} ({e.strerror}), "
                      f"got {value!r}") from None
    too_long = [n for n in path.relative_to(folder).parts if len(os.fsencode(n)) > name_max]
    if too_long or len(os.fsencode(os.path.abspath(path))) >= path_max:
        raise _refuse(f"cannot be written: a name longer than {name_max} bytes or a path longer than "
                      f"{path_max}, got {value[:60]!r}{'...' if len(value) > 60 else ''}")


def output_file(suffixes: tuple[str, ...], what: str) -> Checked:
    """A file to write, ``what`` (e.g. "a linear float EXR"): its name ends in one of ``suffixes``,
    it is not a folder, and it can be created or overwritten. A ``Path``."""
    def convert(value: str) -> Path:
        p = _path(value)
        if _is_dir(p):
            raise _refuse(f"must be a file ending in {' or '.join(suffixes)} ({what}), but {value!r} is a folder")
        if p.suffix.lower() not in suffixes:
            raise _refuse(f"must be a file ending in {' or '.join(suffixes)} ({what}), got {value!r}")
        if _exists(p):
            if not os.access(p, os.W_OK):
                raise _refuse(f"cannot be written: {value!r} is read-only")
        else:
            _check_creatable(p, value)
        return p
    return Checked("output_file", convert, suffixes=suffixes, what=what)


def output_dir() -> Checked:
    """A folder to write into (created if missing): not a file, and a file can be created where it
    is or will be. A ``Path``."""
    def convert(value: str) -> Path:
        p = _path(value)
        if _exists(p) and not _is_dir(p):
            raise _refuse(f"must be a folder, but {value!r} is a file")
        _check_creatable(p, value)
        return p
    return Checked("output_dir", convert)


def output_file_or_dir(suffixes: tuple[str, ...], what: str) -> Checked:
    """A file ending in one of ``suffixes`` (``output_file``) or else a folder (``output_dir``)."""
    as_file, as_dir = output_file(suffixes, what), output_dir()

    def convert(value: str) -> Path:
        return as_file(value) if Path(value).suffix.lower() in suffixes else as_dir(value)
    return Checked("output_file_or_dir", convert, suffixes=suffixes, what=what)


def input_file(what: str, is_one: Callable[[Path], bool] | None = None) -> Checked:
    """An existing readable file, ``what`` (e.g. "a .blend file"), that ``is_one`` accepts. A ``Path``."""
    def convert(value: str) -> Path:
        p = _path(value)
        if not _exists(p):
            raise _refuse(f"must be {what}, but there is no {value!r}")
        if _is_dir(p):
            raise _refuse(f"must be {what}, but {value!r} is a folder")
        if not os.access(p, os.R_OK) or (is_one is not None and not is_one(p)):
            raise _refuse(f"must be {what}, but {value!r} is not one")
        return p
    return Checked("input_file", convert, what=what, checks_content=is_one is not None)


def program(what: str) -> Checked:
    """An existing executable file, ``what`` (e.g. "a Python with bpy"). A ``Path``."""
    def convert(value: str) -> Path:
        p = _path(value)
        if not _exists(p):
            raise _refuse(f"must be {what}, but there is no {value!r}")
        if _is_dir(p) or not os.access(p, os.X_OK):
            raise _refuse(f"must be {what}, but {value!r} is not an executable file")
        return p
    return Checked("program", convert, what=what)

