"""The suite cases a per-case test runs: one of each family in `make test`, every case in
`make test-long` (``lamella_dev.suite.ONE_PER_FAMILY``)."""
import pytest

from lamella_dev import suite


def per_family(cases) -> list:
    """``cases`` as pytest parameters: those of ``suite.ONE_PER_FAMILY`` (and any case not in the
    suite: examples, pending cases) as they are, the other suite cases marked slow."""
    every = set(suite.names())
    return [pytest.param(c, marks=pytest.mark.slow) if c in every and c not in suite.ONE_PER_FAMILY else c
            for c in cases]
