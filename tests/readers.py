"""Running the independent readers (slicers, admesh, FreeCAD, GDAL, dime) from tests."""

import os
import shutil
import subprocess

import pytest


def need(program):
    """Path of ``program``; skip the test without it, but fail under CI, which must install it."""
    path = shutil.which(program)
    if path is None:
        if os.environ.get("CI"):
            pytest.fail(f"{program} is not installed; CI must install it")
        pytest.skip(f"{program} is not installed")
    return path


def run(args, timeout=600, **kw):
    """Run a reader and capture its text output.

    Undecodable bytes are replaced: admesh prints the 80-byte STL header as a C string and
    runs on into the facet count, whose bytes need not be UTF-8.
    """
    return subprocess.run(args, capture_output=True, text=True, errors="replace", timeout=timeout, **kw)


def admesh_counts(path):
    """admesh's report on an STL as ``{label: count}`` (parts, facets fixed, reversed, ...)."""
    import re

    out = run([need("admesh"), str(path)]).stdout
    counts = {k.strip(): int(v) for k, v in re.findall(r"([A-Za-z][A-Za-z ]*?)\s*:\s*(\d+)", out)}
    assert "Number of parts" in counts, out
    return counts
