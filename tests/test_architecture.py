"""Standing checks on the shape of the code base: layering and lint."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("bridge", "simulator", "navigation", "schemas", "clients", "guidance")
# What the message layer (schemas, apart from schemas.runtime) may not touch: it does no I/O,
# keeps no time and starts no threads; process-level helpers live in schemas.runtime.
RUNTIME_ONLY = (
    "asyncio",
    "socket",
    "threading",
    "time",
    "gc",
    "os",
    "threadpoolctl",
    "schemas.runtime",
)


def _run(*cmd: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_import_contracts_hold() -> None:
    """DESIGN.md §2: schemas at the bottom, the bridge and its clients apart, a sans-I/O core."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contracts = len(config["tool"]["importlinter"]["contracts"])
    lint_imports = shutil.which("lint-imports")
    assert lint_imports, "import-linter is part of the test extra: pip install -e '.[test]'"
    result = _run(lint_imports, "--no-cache")
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"Contracts: {contracts} kept, 0 broken." in result.stdout


def test_ruff_is_clean() -> None:
    result = _run(sys.executable, "-m", "ruff", "check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format_is_applied() -> None:
    """One layout everywhere (`ruff format .` before committing), so diffs show changes only."""
    result = _run(sys.executable, "-m", "ruff", "format", "--check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_strict_is_clean() -> None:
    """The packages listed in pyproject's `[tool.mypy] files` type-check under --strict."""
    result = _run(sys.executable, "-m", "mypy")
    assert result.returncode == 0, result.stdout + result.stderr


def _imports(path: Path) -> Iterator[tuple[str, list[str], int]]:
    """(module, imported names, line) of every import statement in `path`."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node.lineno
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module, [alias.name for alias in node.names], node.lineno


def _sources(*packages: str) -> Iterator[Path]:
    for package in packages:
        yield from sorted((ROOT / package).rglob("*.py"))


# The one runtime import the message layer makes: the package's own `__init__` asks where its
# modules load from (the compiled hot path, `schemas.runtime.native`), before any is imported.
PACKAGE_HOOK = (Path("schemas/__init__.py"), "schemas.runtime.native")


def test_the_message_layer_does_no_runtime_work() -> None:
    """schemas' message modules import no clock, socket, thread or process helpers."""
    offences = [
        f"{path.relative_to(ROOT)}:{line}: {module}"
        for path in _sources("schemas")
        if "runtime" not in path.parts
        for module, _names, line in _imports(path)
        if any(module == banned or module.startswith(banned + ".") for banned in RUNTIME_ONLY)
        and (path.relative_to(ROOT), module) != PACKAGE_HOOK
    ]
    assert not offences, "\n".join(offences)


def test_no_private_names_cross_modules() -> None:
    """A leading underscore means "this module's own": no other module imports it."""
    offences = [
        f"{path.relative_to(ROOT)}:{line}: {module}.{name}"
        for path in _sources(*PACKAGES)
        for module, names, line in _imports(path)
        if module.split(".")[0] in PACKAGES
        for name in names
        if name.startswith("_")
    ]
    assert not offences, "\n".join(offences)


def test_every_module_is_named_in_its_packages_readme() -> None:
    """Each package's README maps its rooms: a module it does not name is a room nobody can
    find. Modules in subpackages are named by their path inside the package (`ops/topics.py`);
    `__init__.py` only where it holds more than re-exports is up to the README. Other files
    (`examples/roslibjs_listener.mjs`) are not checked."""
    missing = []
    for package in PACKAGES:
        for path in _sources(package):
            if path.name == "__init__.py":
                continue
            # a subpackage may keep its own README (clients/report/README.md); any README from
            # the module's folder up to the package's names it relative to its own folder
            folders = [path.parent, *path.parent.parents]
            folders = folders[: folders.index(ROOT / package) + 1]
            if not any(
                f"`{path.relative_to(folder).as_posix()}`"
                in (folder / "README.md").read_text(encoding="utf-8")
                for folder in folders
                if (folder / "README.md").exists()
            ):
                missing.append(
                    f"{package}/README.md does not name "
                    f"{path.relative_to(ROOT / package).as_posix()}"
                )
    assert not missing, "\n".join(missing)
