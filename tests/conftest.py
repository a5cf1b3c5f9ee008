"""Fixtures shared by every test package."""

import pytest

from tests.helpers import load_case


@pytest.fixture
def case():
    """``case(name, overrides=None)``: a case file's scene with dotted keys overridden."""
    return load_case
