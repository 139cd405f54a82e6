import os

import numpy as np
import pytest

# Numba caches compiled kernels beside the sources; keep test runs from different
# checkouts from sharing stale caches.
os.environ.setdefault("NUMBA_CACHE_DIR", os.path.join(os.path.dirname(__file__), "..", ".numba_cache"))


@pytest.fixture
def rng():
    return np.random.default_rng(1234)
