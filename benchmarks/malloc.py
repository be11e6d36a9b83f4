"""Re-run a benchmark under the tuned glibc malloc thresholds the project's processes use.

glibc reads `MALLOC_*` only at start, so a benchmark whose own process allocates scan-sized
buffers replaces itself with a copy started with them (`schemas.runtime.process.MALLOC_ENV`),
as `python -m benchmarks.<name>` with this checkout first on PYTHONPATH.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from typing import NoReturn

from schemas.runtime.process import MALLOC_ENV
from tests.child_process import repo_env


def malloc_tuned() -> bool:
    """Whether this process started with the tuned thresholds."""
    return all(os.environ.get(key) == value for key, value in MALLOC_ENV.items())


def rerun_tuned(module: str, args: Sequence[str]) -> NoReturn:
    """Replace this process by `python -m module *args` with the tuned thresholds."""
    os.execve(sys.executable, [sys.executable, "-m", module, *args], repo_env(MALLOC_ENV))
