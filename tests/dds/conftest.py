"""Fixtures for the DDS tests: a domain id of their own, on the loopback interface only."""

from __future__ import annotations

import os
import random
import time

import pytest

# Domains 100..230 on the loopback: clear of ROS 2's default 0 and of each other's test runs.
FIRST_TEST_DOMAIN, LAST_TEST_DOMAIN = 100, 230


@pytest.fixture
def dds_domain() -> int:
    """A domain id unlikely to be used by anything else on this machine right now."""
    return random.Random(os.getpid() ^ time.time_ns()).randint(FIRST_TEST_DOMAIN,
                                                               LAST_TEST_DOMAIN)
