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
    """Where compiled shaders are cached (the installed extension: its user folder)."""
    global _cache_root
    _cache_root = Path(path) if path is not None else None


def cache_dir() -> Path:
    base = _cache_root or os.environ.get("LAMELLA_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "lamella")
    d = Path(base) / "oso"
    d.mkdir(parents=True, exist_ok=True)
    return d


def source_hash(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()


def _capture_fd2(fn):
    """Run ``fn()`` with the C-level stderr captured; returns (result, captured text)."""
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            result = fn()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
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
        ok, log = _capture_fd2(lambda: _cycles.osl_compile(str(src), str(out)))
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
    """``assign_script`` for a shader already compiled to ``oso``. Every input socket takes its
    parameter's default: a socket kept from an earlier shader (and its links) gets the new value."""
    import cycles.osl
    import oslquery

    text.clear()
    text.write(source)
    node.mode = "INTERNAL"
    node.script = text
    bytecode = oso.read_text()
    node.bytecode = bytecode
    node.bytecode_hash = hashlib.md5(bytecode.encode(), usedforsecurity=False).hexdigest()
    query = oslquery.OSLQuery(str(oso))
    if not query:
        raise OSLCompileError(f"OSL query failed to read the compiled shader {oso}")
    used = set()
    for param in query.parameters:
        sock = cycles.osl.shader_param_ensure(node, param)
        if sock is not None:
            used.add(sock)
            if not param.isoutput and param.value is not None and not param.isclosure:
                value = param.value
                sock.default_value = value if isinstance(value, (str, int, float)) else tuple(value)
    for sockets in (node.inputs, node.outputs):
        for identifier in [s.identifier for s in sockets]:
            if sockets[identifier] not in used:
                sockets.remove(sockets[identifier])
