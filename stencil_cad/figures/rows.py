"""Rows whose typed fields are some of their keys: the rest kept as written, in the written order.

A plate's row holds its solid's check (whose keys ``cad/`` chooses), its cut files' offsets and
its sizes; the sheet and the summary read a dozen of them. A :class:`KeyedRow` types those as
fields and keeps the others in ``other``, with the keys in the order the row was written, so
``from_json`` then ``to_json`` gives the same JSON back, key for key and in the same order.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, TypeVar

#: A mapping as the manifest holds it (values are JSON: numbers, strings, lists, mappings).
Row = Mapping[str, Any]

_R = TypeVar("_R", bound="KeyedRow")


def to_json(value: Any) -> Any:
    """A figure as the manifest writes it: a figures object by its ``to_json``, a tuple item by item."""
    if hasattr(value, "to_json"):
        return value.to_json()
    if isinstance(value, tuple):
        return [to_json(v) for v in value]
    return value


def rows_of(read: Callable[[Row], Any], rows: Any) -> tuple[Any, ...]:
    """Each mapping of a manifest list read by ``read`` (anything else in the list is skipped)."""
    return tuple(read(r) for r in rows or () if isinstance(r, Mapping))


@dataclass(frozen=True)
class KeyedRow:
    """A manifest row: typed fields for the keys read, ``other`` for the rest, ``keys`` for the order.

    A subclass declares its typed fields (each ``None`` when the row lacks its key) and, in
    ``nested``, how to read a field that is itself a row.
    """

    #: The row's keys that have no field, as written.
    other: Row = field(default_factory=dict, kw_only=True, repr=False)
    #: Every key of the row in the order it was written (typed or not).
    keys: tuple[str, ...] = field(default=(), kw_only=True, repr=False)

    #: How to read a typed field's value that is itself a row (by field name).
    nested: ClassVar[Mapping[str, Callable[[Any], Any]]] = {}

    @classmethod
    def typed(cls) -> tuple[str, ...]:
        """The names of the row's typed fields."""
        return tuple(f.name for f in fields(cls) if f.name not in ("other", "keys"))

    @classmethod
    def from_json(cls: type[_R], row: Row) -> _R:
        """The row as a manifest (or a stage) writes it."""
        typed = cls.typed()
        values = {k: cls.nested.get(k, _same)(row[k]) for k in typed if k in row}
        other = {k: v for k, v in row.items() if k not in typed}
        return cls(**values, other=other, keys=tuple(row))

    def has(self, key: str) -> bool:
        """Whether the row was written with ``key``."""
        return key in self.keys

    def to_json(self) -> dict[str, Any]:
        """The row as it was written: the same keys, in the same order."""
        typed = set(self.typed())
        return {k: to_json(getattr(self, k)) if k in typed else self.other[k] for k in self.keys}


def _same(value: Any) -> Any:
    return value
