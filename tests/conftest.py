"""Fixtures shared by every test package, and one thread for the sparse direct solver."""

import os

# PARDISO (MKL) on one thread, set before MKL loads: the tests check numbers, not speed, and
# on a 2-core machine where another process holds a core, MKL's second thread made
# factorizations up to 7x slower (docs/solvers.md#p1-finite-elements); one thread also sums
# in the same order every time.
os.environ.setdefault("MKL_NUM_THREADS", "1")

import pytest  # noqa: E402

from tests.helpers import load_case  # noqa: E402


@pytest.fixture
def case():
    """``case(name, overrides=None)``: a case file's scene with dotted keys overridden."""
    return load_case
