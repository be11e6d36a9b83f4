"""Fixtures for the bridge tests."""

from __future__ import annotations

import pytest

from schemas.registry import TypeRegistry
from tests.bridge.bridge_harness import CoreHarness


@pytest.fixture
def harness(registry: TypeRegistry) -> CoreHarness:
    return CoreHarness(registry)
