"""Compiling generated OSL through Blender's bundled compiler, with a cache by source hash and
errors that show the offending lines (issue 3: "never a silent black material").

Cycles' own path (``cycles.osl.update_script_node``) compiles an INTERNAL text on every call and
sends compiler errors to the process's stderr only. Here the source is compiled once per distinct
text (``<sha256>.oso`` in the cache folder), compiler output is captured from file descriptor 2,
and the Script node gets the bytecode and sockets exactly as Cycles would give them, while
keeping the source as an INTERNAL text datablock, so the shader travels with the .blend.
"""
from __future__ import annotations

import hashlib
import os
import re
import tempfile
from pathlib import Path


class OSLCompileError(RuntimeError):
    """The OSL compiler rejected a shader; the message quotes the offending lines."""


_cache_root: Path | None = None


def set_cache_root(path) -> None:
    """Where compiled shaders are cached (the installed extension: its user folder); the
    LAMELLA_CACHE environment variable still takes precedence."""
    global _cache_root
    _cache_root = Path(path) if path is not None else None


def cache_dir() -> Path:
    base = os.environ.get("LAMELLA_CACHE") or _cache_root or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "lamella")
    d = Path(base) / "oso"
    d.mkdir(parents=True, exist_ok=True)
    return d


# A shader parameter's declaration as the OSL printer writes it, and the stack comment: two sources
# that differ only there are the same shader with other parameter values.
_PARAM = re.compile(r"^    (float|int) (\w+) = ([^,\n]+),$", re.M)
_STACK_LINE = re.compile(r"^// stack: .*$", re.M)


def source_hash(source: str) -> str:
    """The cache key of ``source``: its structure, not its parameter values. Every layer value is
    a shader parameter whose socket carries the value, so a value edit reuses the compiled
    shader of the same structure (``assign_compiled`` sets the sockets from the source)."""
    structure = _PARAM.sub(r"    \1 \2 = 0,", _STACK_LINE.sub("", source))
    return hashlib.sha256(structure.encode()).hexdigest()


def source_params(source: str) -> dict[str, float | int]:
    """The parameter defaults ``source`` declares (the stack's values)."""
    return {m.group(2): (int(m.group(3)) if m.group(1) == "int" else float(m.group(3)))
            for m in _PARAM.finditer(source)}


def capture_stderr(fn, fds=(2,)):
    """Run ``fn()`` with the C-level stderr (and any other file descriptors in ``fds``: Blender's
    log goes to stdout) captured; returns (result, captured text)."""
    import sys

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


def compile_source(source: str, name: str = "shader") -> Path:
    """The .oso of ``source``, compiled once per distinct source text. Raises OSLCompileError."""
    import _cycles

    oso = cache_dir() / f"{source_hash(source)}.oso"
    if oso.exists() and oso.stat().st_size > 0:
        return oso
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"{name}.osl"
        src.write_text(source)
        out = Path(tmp) / f"{name}.oso"
        ok, log = capture_stderr(lambda: _cycles.osl_compile(str(src), str(out)))
        if not ok or not out.exists():
            raise OSLCompileError(format_errors(source, log, name))
        tmp_oso = oso.with_suffix(f".{os.getpid()}.tmp")
        tmp_oso.write_bytes(out.read_bytes())
        tmp_oso.replace(oso)  # atomic: parallel test workers may compile the same shader
    return oso


def assign_script(node, text, source: str, name: str = "shader") -> None:
    """Make Script ``node`` run ``source``: INTERNAL mode on ``text`` (which receives the source),
    bytecode from the cache, one socket per shader parameter (Cycles' own socket rules)."""
    assign_compiled(node, text, source, compile_source(source, name))


def assign_compiled(node, text, source: str, oso: Path) -> None:
    """``assign_script`` for a shader already compiled to ``oso`` (possibly from a source of the
    same structure with other parameter values). Every input socket takes the default ``source``
    declares: a socket kept from an earlier shader (and its links) gets the new value."""
    import cycles.osl

    text.clear()
    text.write(source)
    node.mode = "INTERNAL"
    node.script = text
    bytecode = oso.read_text()
    node.bytecode = bytecode
    node.bytecode_hash = hashlib.md5(bytecode.encode(), usedforsecurity=False).hexdigest()
    try:
        import oslquery
    except ImportError:  # Blender 4.2 to 4.4: Cycles makes the sockets itself, in C++
        _update_sockets_in_cycles(node, source, oso)
        return
    query = oslquery.OSLQuery(str(oso))
    if not query:
        raise OSLCompileError(f"OSL query failed to read the compiled shader {oso}")
    used = set()
    values = source_params(source)
    for param in query.parameters:
        sock = cycles.osl.shader_param_ensure(node, param)
        if sock is not None:
            used.add(sock)
            if param.isoutput or param.isclosure:
                continue
            if param.name in values:
                sock.default_value = values[param.name]
            elif isinstance(param.value, str):  # the tables' folder
                sock.default_value = param.value
    for sockets in (node.inputs, node.outputs):
        for identifier in [s.identifier for s in sockets]:
            if sockets[identifier] not in used:
                sockets.remove(sockets[identifier])


def _update_sockets_in_cycles(node, source: str, oso: Path) -> None:
    """Blender before 4.5 has no ``oslquery`` module: Cycles' ``osl_update_node`` reads the
    shader's parameters and makes (and removes) the sockets; then every input takes the default
    ``source`` declares."""
    import _cycles
    import bpy

    if not _cycles.osl_update_node(bpy.data.as_pointer(), node.id_data.as_pointer(), node.as_pointer(), str(oso)):
        raise OSLCompileError(f"Cycles failed to read the compiled shader {oso}")
    values = source_params(source)
    for sock in node.inputs:
        if sock.name in values and hasattr(sock, "default_value"):
            sock.default_value = values[sock.name]
