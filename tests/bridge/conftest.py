"""Fixtures for the bridge tests."""

from __future__ import annotations

import pytest
from bridge_harness import CoreHarness

from schemas.registry import TypeRegistry


@pytest.fixture
def harness(registry: TypeRegistry) -> CoreHarness:
    return CoreHarness(registry)
