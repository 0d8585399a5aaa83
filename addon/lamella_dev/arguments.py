"""Argument types shared by the ``lamella`` command and the benches' own options."""
from __future__ import annotations

import argparse


def count(what: str, hi: int | None = None):
    """An argparse type: a whole number from 1 (to ``hi``), else exit code 2 with one line."""
    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a whole number, got {text!r}") from None
        if n < 1 or (hi is not None and n > hi):
            raise argparse.ArgumentTypeError(f"{what} must be from 1 to {hi}, got {n}" if hi is not None
                                             else f"{what} must be 1 or more, got {n}")
        return n
    return parse
