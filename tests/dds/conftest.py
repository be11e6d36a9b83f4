"""Fixtures for the DDS tests: a domain id of their own, on the loopback interface only."""

from __future__ import annotations

import os
import random
import time

import pytest

# Domains 100..230 on the loopback: clear of ROS 2's default 0 and of each other's test runs.
FIRST_TEST_DOMAIN, LAST_TEST_DOMAIN = 100, 230


_DOMAINS = list(range(FIRST_TEST_DOMAIN, LAST_TEST_DOMAIN + 1))
random.Random(os.getpid() ^ time.time_ns()).shuffle(_DOMAINS)


def take_domain() -> int:
    """A domain id unlikely to be used by anything else on this machine right now (and not
    by an earlier test of this session, whose participants may linger in other processes)."""
    return _DOMAINS.pop()


@pytest.fixture
def dds_domain() -> int:
    """`take_domain()` for one test."""
    return take_domain()
