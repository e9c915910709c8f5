"""The Examples sections of the docstrings run and give what they show (on the installed package)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import ema_rig

MODULES = sorted(info.name for info in pkgutil.walk_packages(ema_rig.__path__, "ema_rig."))


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples failed in {name}"
