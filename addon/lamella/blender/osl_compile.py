"""Compiling generated OSL through Blender's bundled compiler, with a cache by source hash and
errors that show the offending lines: never a silent black material.

Cycles' own path (``cycles.osl.update_script_node``) compiles an INTERNAL text on every call and
sends compiler errors to the process's stderr only. Here the source is compiled once per distinct
text (``<sha256>.oso`` in the cache folder), compiler output is captured from file descriptor 2,
and the Script node gets the bytecode and sockets exactly as Cycles would give them, while
keeping the source as an INTERNAL text datablock, so the shader travels with the .blend.
"""
from __future__ import annotations

import atexit
import hashlib
import os
import re
import shutil
import struct
import sys
import tempfile
from pathlib import Path

import _cycles
import bpy
import cycles.osl

try:  # Blender 4.5 and newer; before, Cycles reads a compiled shader's parameters itself
    import oslquery
except ImportError:
    oslquery = None


class OSLCompileError(RuntimeError):
    """The OSL compiler rejected a shader; the message quotes the offending lines."""


_cache_root: Path | None = None


def set_cache_root(path) -> None:
    """Where compiled shaders are cached (the installed extension: its user folder); the
    LAMELLA_CACHE environment variable still takes precedence."""
    global _cache_root
    _cache_root = Path(path) if path is not None else None


def cache_dir() -> Path:
    """The folder compiled shaders are cached in: the user folder's, or, where that cannot be
    written (a read-only or full disk), a temporary folder of this session's (said once, on
    stderr: shaders then compile again in every session; nothing else changes)."""
    global _fallback
    if _fallback is not None:
        return _fallback
    base = os.environ.get("LAMELLA_CACHE") or _cache_root or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "lamella")
    d = Path(base) / "oso"
    try:
        d.mkdir(parents=True, exist_ok=True)
        probe = d / f".probe.{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        return d
    except OSError as e:
        return _use_fallback(d, e)


_fallback: Path | None = None


def _use_fallback(d: Path, error: OSError) -> Path:
    """Switch the cache to a temporary folder for the rest of the session, saying why once."""
    global _fallback
    _fallback = Path(tempfile.mkdtemp(prefix="lamella_oso_"))
    atexit.register(shutil.rmtree, _fallback, True)
    print(f"Lamella: the shader cache {d} cannot be written ({error.strerror or error}); shaders compile "
          f"without a cache in this session", file=sys.stderr)
    return _fallback


def source_hash(source: str) -> str:
    """The cache key of ``source``: the text itself. A staged shader carries its material table,
    so a value edit is a new source; a shader of the same stack and values compiles once."""
    return hashlib.sha256(source.encode()).hexdigest()


def capture_stderr(fn, fds=(2,)):
    """Run ``fn()`` with the C-level stderr (and any other file descriptors in ``fds``: Blender's
    log goes to stdout) captured; returns (result, captured text)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in fds]
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        for fd in fds:
            os.dup2(tmp.fileno(), fd)
        try:
            result = fn()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            for fd, s in zip(fds, saved):
                os.dup2(s, fd)
                os.close(s)
        tmp.seek(0)
        return result, tmp.read().decode(errors="replace")


def format_errors(source: str, compiler_output: str, name: str, context: int = 2) -> str:
    """The compiler's messages, each followed by the source lines around the line it names."""
    lines = source.splitlines()
    out = [f"OSL compile failed for {name}:"]
    for msg in compiler_output.splitlines():
        if not msg.strip():
            continue
        out.append(f"  {msg.strip()}")
        m = re.search(r":(\d+):\s*(error|warning)", msg)
        if m:
            n = int(m.group(1))
            for k in range(max(1, n - context), min(len(lines), n + context) + 1):
                out.append(f"    {'>' if k == n else ' '}{k:5d} | {lines[k - 1]}")
    if len(out) == 1:
        out.append("  (the compiler gave no message)")
    return "\n".join(out)


def loads(oso: Path) -> bool:
    """Whether Blender can read the compiled shader ``oso`` back (its parameters): a cache entry
    written by another version, cut short or holding a value the reader rejects does not."""
    if oslquery is None:  # Blender before 4.5: no reader; the compiler's own success is the test
        return oso.exists() and oso.stat().st_size > 0
    try:
        return bool(oslquery.OSLQuery(str(oso)))
    except Exception:  # noqa: BLE001 - any failure to read means the entry is unusable
        return False


def compile_source(source: str, name: str = "shader") -> Path:
    """The .oso of ``source``, compiled once per distinct source text. A cached entry that does
    not load (``loads``) is discarded and compiled again. Raises OSLCompileError."""
    oso = cache_dir() / f"{source_hash(source)}.oso"
    if oso.exists() and oso.stat().st_size > 0:
        if capture_stderr(lambda: loads(oso))[0]:
            return oso
        oso.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"{name}.osl"
        src.write_text(source)
        out = Path(tmp) / f"{name}.oso"
        ok, log = capture_stderr(lambda: _cycles.osl_compile(str(src), str(out)))
        if not ok or not out.exists():
            raise OSLCompileError(format_errors(source, log, name))
        loaded, log = capture_stderr(lambda: loads(out))
        if not loaded:
            raise OSLCompileError(format_errors(source, log, name) + "\n  (compiled, but the result does not load)")
        try:
            tmp_oso = oso.with_suffix(f".{os.getpid()}.tmp")
            tmp_oso.write_bytes(out.read_bytes())
            tmp_oso.replace(oso)  # atomic: parallel test workers may compile the same shader
        except OSError as e:  # the disk filled up, or the folder turned read-only
            oso = _use_fallback(oso.parent, e) / oso.name
            oso.write_bytes(out.read_bytes())
    return oso


def set_socket(sock, value) -> None:
    """Set an input socket to ``value``: a float, or an RGB triple (a colour socket holds RGBA)."""
    if isinstance(value, (tuple, list)) and len(value) == 3 and len(sock.default_value) == 4:
        value = (*value, 1.0)
    if _stored(value) != _stored(sock.default_value):  # an unchanged socket is left alone (no update)
        sock.default_value = value


def _stored(value):
    """``value`` as a socket stores it (a number in float32, a colour or vector as a tuple, a
    string as it is)."""
    if isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return struct.unpack("f", struct.pack("f", value))[0]
    return tuple(_stored(v) for v in value)


def assign_script(node, text, source: str, name: str = "shader", values: dict | None = None) -> None:
    """Make Script ``node`` run ``source``: INTERNAL mode on ``text`` (which receives the source),
    bytecode from the cache, one socket per shader parameter (Cycles' own socket rules), each
    set to its value in ``values`` (by default the parameter's default)."""
    assign_compiled(node, text, source, compile_source(source, name), values)


def assign_compiled(node, text, source: str, oso: Path, values: dict | None = None) -> None:
    """``assign_script`` for a shader already compiled to ``oso``. Every input socket named in
    ``values`` takes that value: a socket kept from an earlier shader (and its links) gets the new
    value; the others take the shader's defaults."""
    text.clear()
    text.write(source)
    node.mode = "INTERNAL"
    node.script = text
    bytecode = oso.read_text()
    node.bytecode = bytecode
    node.bytecode_hash = hashlib.md5(bytecode.encode(), usedforsecurity=False).hexdigest()
    if oslquery is None:  # Blender 4.2 to 4.4: Cycles makes the sockets itself, in C++
        _update_sockets_in_cycles(node, values or {}, oso)
        return
    query = oslquery.OSLQuery(str(oso))
    if not query:
        raise OSLCompileError(f"OSL query failed to read the compiled shader {oso}")
    used = set()
    values = values or {}
    for param in query.parameters:
        sock = cycles.osl.shader_param_ensure(node, param)
        if sock is not None:
            used.add(sock)
            if param.isoutput or param.isclosure:
                continue
            if param.name in values:
                set_socket(sock, values[param.name])
            elif isinstance(param.value, str):  # the tables' folder
                sock.default_value = param.value
    for sockets in (node.inputs, node.outputs):
        for identifier in [s.identifier for s in sockets]:
            if sockets[identifier] not in used:
                sockets.remove(sockets[identifier])


def _update_sockets_in_cycles(node, values: dict, oso: Path) -> None:
    """Blender before 4.5 has no ``oslquery`` module: Cycles' ``osl_update_node`` reads the
    shader's parameters and makes (and removes) the sockets; then every input takes the default
    ``source`` declares."""
    if not _cycles.osl_update_node(bpy.data.as_pointer(), node.id_data.as_pointer(), node.as_pointer(), str(oso)):
        raise OSLCompileError(f"Cycles failed to read the compiled shader {oso}")
    for sock in node.inputs:
        if sock.name in values and hasattr(sock, "default_value"):
            set_socket(sock, values[sock.name])
