"""`pip install riverbridge` without extras: a small environment that runs the bridge.

Runs scripts/light_install.py, which installs this checkout into a fresh venv (from the local
package index, offline-safe here), checks its size and that no heavy library came along, and
has the installed client library publish through the installed `riverbridge bridge`.
"""

import os
import subprocess
import sys

import pytest

from tests.child_process import REPO_ROOT

pytestmark = pytest.mark.slow

MAX_VENV_MB = 250


@pytest.mark.timeout(900)
def test_the_light_install_runs_the_bridge_without_heavy_libraries(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    result = subprocess.run(
        [
            sys.executable,
            str(REPO_ROOT / "scripts" / "light_install.py"),
            "--venv",
            str(tmp_path / "venv"),
            "--max-mb",
            str(MAX_VENV_MB),
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=840,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "heavy libraries installed: none" in result.stdout
    assert "served a publish/subscribe" in result.stdout
    assert "pip install 'riverbridge[sim]'" in result.stdout
