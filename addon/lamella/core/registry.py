"""The one shape of every extension point (docs/design.md "Where a new kind goes"): a named table
that modules join with ``register`` and leave with ``unregister``.

Layer kinds, lobe kinds, traced operations and models each keep one :class:`Registry`; the
development benches (``lamella_dev.bench``) keep one too. A registry refuses a name it (or a
registry it shares its names with, as coats share theirs with bases) holds already, and runs its
completeness check on every entry before accepting it, so a kind that lacks what its readers need
fails where it is declared, not at its first use. Readers treat a registry as a read-only mapping
from names to entries.
"""
from __future__ import annotations

from typing import Callable, Generic, Iterator, Mapping, TypeVar

T = TypeVar("T")


class Registry(Mapping[str, T], Generic[T]):
    """A named table of ``what`` (e.g. "lobe kind"): ``key(entry)`` is an entry's name (its
    ``name`` attribute by default); ``check(entry)`` raises ``ValueError`` or ``TypeError`` saying
    what an entry lacks; ``shares_names_with``: registries whose names this one may not reuse."""

    def __init__(self, what: str, check: Callable[[T], None] | None = None,
                 key: Callable[[T], str] = lambda entry: entry.name, shares_names_with: tuple = ()):
        self.what = what
        self._check = check
        self._key = key
        self._entries: dict[str, T] = {}
        self._shared = list(shares_names_with)
        for other in self._shared:
            other._shared.append(self)

    def register(self, entry: T) -> T:
        """Add ``entry`` (after its completeness check) and return it."""
        name = self._key(entry)
        if not isinstance(name, str) or not name:
            raise ValueError(f"a {self.what} needs a name, got {name!r}")
        for table in (self, *self._shared):
            if name in table._entries:
                raise ValueError(f"a {table.what} named {name!r} is registered already")
        if self._check is not None:
            self._check(entry)
        self._entries[name] = entry
        return entry

    def unregister(self, entry_or_name) -> None:
        """Remove an entry, given as itself or by name; an entry registered under its name by
        someone else stays. Unknown names are ignored (unregistering is idempotent)."""
        name = entry_or_name if isinstance(entry_or_name, str) else self._key(entry_or_name)
        held = self._entries.get(name)
        if held is not None and (isinstance(entry_or_name, str) or held is entry_or_name):
            del self._entries[name]

    def require(self, name: str) -> T:
        """The entry ``name``, or a ``ValueError`` listing what is registered."""
        if name not in self._entries:
            raise ValueError(f"unknown {self.what} {name!r}; registered: {', '.join(self._entries) or 'none'}")
        return self._entries[name]

    def __getitem__(self, name: str) -> T:
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.what!r}: {', '.join(self._entries)})"


def require_callables(what: str, entry, *names: str) -> None:
    """A completeness check: ``entry`` has each attribute of ``names`` and each is callable."""
    missing = [n for n in names if not callable(getattr(entry, n, None))]
    if missing:
        label = getattr(entry, "name", None) or getattr(entry, "type", None) or repr(entry)
        raise TypeError(f"{what} {label!r} lacks {', '.join(missing)} (each a function)")


__all__ = ["Registry", "require_callables"]
