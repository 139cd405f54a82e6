"""What a job computes again and again from the same inputs, kept for the next call in this process.

A job sprays the same holes and windows and scores against the same reference in several
simulations (the prior's cans, the sweep card's panels, a mural's registration cases); the
simulation's helpers keep their last few results by a digest of their inputs.
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable
from typing import Any

import numpy as np


def digest(*arrays: Any) -> bytes:
    """A digest of arrays' shapes and float64 values (equal inputs, equal digests)."""
    h = hashlib.blake2b(digest_size=20)
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=np.float64)
        h.update(str(a.shape).encode())
        h.update(a.data)
    return h.digest()


class Kept:
    """The last ``size`` results by key, the most recently used kept longest; safe across threads.

    The studio's previews and a job's tasks compute from several threads at once.

    Args:
        size: How many results to keep.
        max_bytes: At most this many bytes of results (arrays' ``nbytes``) kept, the most recent
            result always, or None: no bound but ``size``.
    """

    def __init__(self, size: int, max_bytes: int | None = None):
        self.size = size
        self.max_bytes = max_bytes
        self._items: dict[Any, Any] = {}
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._items)

    def clear(self) -> None:
        """Forget every kept result."""
        with self._lock:
            self._items.clear()

    def get(self, key: Any, make: Callable[[], Any]) -> Any:
        """The result kept for ``key``, else ``make()`` (kept from now on)."""
        with self._lock:
            value = self._items.pop(key, None)
        if value is None:
            value = make()
        with self._lock:
            self._items[key] = value  # the most recent last
            while len(self._items) > self.size or (len(self._items) > 1 and self._over_bytes()):
                del self._items[next(iter(self._items))]
        return value

    def _over_bytes(self) -> bool:
        if self.max_bytes is None:
            return False
        return sum(int(getattr(v, "nbytes", 0)) for v in self._items.values()) > self.max_bytes
