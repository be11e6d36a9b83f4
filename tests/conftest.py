"""Fixtures every test folder shares: the type registry, the canonical-message checker, and
this checkout first on every child process's PYTHONPATH."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from schemas.codec_cdr import from_cdr, to_cdr
from schemas.message import normalize
from schemas.registry import TypeRegistry
from tests.child_process import repo_env
from tests.memory_pair import MemoryPair


def assert_same(expected: Any, actual: Any, path: str = "msg") -> None:
    """Deep equality that also demands equal Python types and ndarray dtypes."""
    if isinstance(expected, np.ndarray):
        assert isinstance(actual, np.ndarray), f"{path}: {type(actual).__name__} not ndarray"
        assert actual.dtype == expected.dtype, f"{path}: dtype {actual.dtype} != {expected.dtype}"
        np.testing.assert_array_equal(actual, expected, err_msg=path)
        return
    assert type(actual) is type(expected), (
        f"{path}: {type(actual).__name__} != {type(expected).__name__}"
    )
    if isinstance(expected, dict):
        assert actual.keys() == expected.keys(), f"{path}: keys differ"
        for key in expected:
            assert_same(expected[key], actual[key], f"{path}.{key}")
    elif isinstance(expected, list):
        assert len(actual) == len(expected), f"{path}: length differs"
        for i, (e, a) in enumerate(zip(expected, actual, strict=True)):
            assert_same(e, a, f"{path}[{i}]")
    elif isinstance(expected, float) and math.isnan(expected):
        assert math.isnan(actual), path
    else:
        assert actual == expected, f"{path}: {actual!r} != {expected!r}"


@pytest.fixture(scope="session")
def registry() -> TypeRegistry:
    return TypeRegistry.with_defaults()


@pytest.fixture(scope="session")
def check_canonical(registry: TypeRegistry) -> Callable[[str, dict], None]:
    """Assert a message dict is already canonical (normalising it changes nothing, no field is
    missing or extra) and survives a CDR round trip unchanged."""

    def check(type_name: str, msg: dict) -> None:
        spec = registry.message(type_name)
        assert_same(msg, normalize(spec, msg, now_ns=0))
        assert_same(msg, from_cdr(registry, type_name, to_cdr(registry, type_name, msg)))

    return check


@pytest.fixture(scope="session", autouse=True)
def children_import_this_checkout() -> Iterator[None]:
    """pytest puts the checkout first on its own sys.path (pyproject `pythonpath`); a child
    process (`python -m bridge`, `riverbridge.py`) started without an explicit environment must
    import the same copy, not an installed one, so PYTHONPATH names it first for the session."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("PYTHONPATH", repo_env()["PYTHONPATH"])
        yield


@pytest.fixture
def memory_pair(registry: TypeRegistry) -> MemoryPair:
    """The client library's protocol and the bridge's core, talking in memory (no sockets)."""
    return MemoryPair(registry)
