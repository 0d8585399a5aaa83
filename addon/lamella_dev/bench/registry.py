"""The benchmarks behind ``lamella bench``, by name: each bench module registers one ``Bench`` at
its bottom, and the command is built from this table (``lamella_dev.cli``: one subcommand per
bench, its description as the help, its own options, and ``--out`` for every bench).

A bench's ``run(out_dir, args)`` writes its page into ``out_dir`` (``page.write_page``) and
returns the page's path; ``args`` is the parsed command line (an ``argparse.Namespace``), holding
the options its ``arguments(parser)`` declared. A bench module imports nothing heavy (bpy,
matplotlib, tqdm) at its top: importing ``lamella_dev.bench`` imports every bench module.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from lamella.core.registry import Registry

RESERVED = ("list",)  # `lamella bench list` names the benches


@dataclass(frozen=True)
class Bench:
    """One benchmark: ``name`` as typed after ``lamella bench``; ``description``, one line (the
    command's help); ``run(out_dir, args) -> Path``, the page it wrote; ``arguments(parser)``,
    optional, adds the bench's own options to its subcommand's parser."""

    name: str
    description: str
    run: Callable[[Path, argparse.Namespace], Path]
    arguments: Callable[[argparse.ArgumentParser], None] | None = None


def _check(bench: Bench) -> None:
    """The completeness check: a ValueError says what ``bench`` lacks."""
    name = bench.name
    if name.startswith("-") or any(c.isspace() for c in name):
        raise ValueError(f"a bench's name is one word typed after `lamella bench`, got {name!r}")
    if name in RESERVED:
        raise ValueError(f"bench {name!r}: `lamella bench {name}` is the command's own")
    d = bench.description
    if not isinstance(d, str) or not d.strip() or "\n" in d or "\r" in d or d != d.strip():
        raise ValueError(f"bench {name!r}: the description is one line of text, got {d!r}")
    if not callable(bench.run):
        raise ValueError(f"bench {name!r}: run is a function (out_dir, args) -> the page's path, got {bench.run!r}")
    if bench.arguments is not None and not callable(bench.arguments):
        raise ValueError(f"bench {name!r}: arguments is a function (parser) or None, got {bench.arguments!r}")


BENCHES: Registry[Bench] = Registry("bench", _check)  # name -> Bench: join with register


def register(bench: Bench) -> Bench:
    """Add ``bench`` to the table (``lamella bench <name>``) and return it. A name registered
    already, or a bench that lacks a part (``_check``), raises ValueError naming it."""
    if not isinstance(bench, Bench):
        raise ValueError(f"register takes a Bench, got {bench!r}")
    return BENCHES.register(bench)


def unregister(bench_or_name: Bench | str) -> None:
    """Remove a bench (an extension's), given as itself or by name; a bench registered under that
    name by someone else stays. Unknown names are ignored."""
    BENCHES.unregister(bench_or_name)


def cases_argument(parser: argparse.ArgumentParser, choices: Callable[[], list[str]] | None = None,
                   what: str = "suite case") -> None:
    """``--cases a,b,c``: the cases to run (``args.cases``: a list, None for the default), each one
    of ``choices()`` (default: the suite's cases), checked as the command line is parsed."""
    from ..arguments import names

    def suite_cases() -> list[str]:
        from .. import suite

        return suite.names()

    parser.add_argument("--cases", type=names(what, choices or suite_cases),
                        help=f"comma-separated {what}s (default: all)")
