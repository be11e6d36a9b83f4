"""config/sim.toml, config/nav.toml and config/guidance.toml list every setting of the
pydantic models, with its default and where it comes from; and nothing else (both
directions)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

from guidance.config import GuidanceConfig
from navigation.config import NavigationConfig
from simulator.config import SimConfig

CONFIG = Path(__file__).resolve().parents[1] / "config"
FILES = [
    (CONFIG / "sim.toml", SimConfig),
    (CONFIG / "nav.toml", NavigationConfig),
    (CONFIG / "guidance.toml", GuidanceConfig),
]
SETTING = re.compile(r"^# (\[[\w.]+\]|\w+ = )")
CITED = re.compile(r"#.*#\s*(.*\b(thesis|ours|unset|standard)\b.*)$")


def uncommented(path: Path) -> str:
    """The file with its commented-out settings and table headers switched on."""
    return "\n".join(
        line[2:] if SETTING.match(line) else line
        for line in path.read_text(encoding="utf-8").splitlines()
    )


def dotted(table: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in table.items():
        if isinstance(value, dict):
            out.update(dotted(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def model_defaults(model: BaseModel, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in type(model).model_fields:
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            out.update(model_defaults(value, f"{prefix}{name}."))
        else:
            out[f"{prefix}{name}"] = value
    return out


@pytest.mark.parametrize(("path", "model"), FILES, ids=["sim", "nav", "guidance"])
def test_the_file_lists_every_setting_and_no_other(path, model):
    listed = set(dotted(tomllib.loads(uncommented(path))))
    fields = set(model_defaults(model()))
    assert not fields - listed, f"missing from {path.name}: {sorted(fields - listed)}"
    assert not listed - fields, f"not settings of {model.__name__}: {sorted(listed - fields)}"


@pytest.mark.parametrize(("path", "model"), FILES, ids=["sim", "nav", "guidance"])
def test_the_listed_values_are_the_defaults(path, model):
    data = tomllib.loads(uncommented(path))
    defaults = model_defaults(model())
    unset = [key for key, value in defaults.items() if value is None]
    lines = path.read_text(encoding="utf-8").splitlines()
    for key in unset:  # TOML has no null: such keys show an example and say "unset"
        name = key.rsplit(".", 1)[-1]
        line = next(x for x in lines if x.startswith(f"# {name} = "))
        assert "default: unset" in line, line
        table = data
        for part in key.split(".")[:-1]:
            table = table[part]
        del table[name]
    assert model.model_validate(data) == model(), "a listed value differs from the default"


@pytest.mark.parametrize(("path", "model"), FILES, ids=["sim", "nav", "guidance"])
def test_every_setting_says_where_it_comes_from(path, model):
    header_cited = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if not SETTING.match(line):
            continue
        cited = bool(CITED.match(line))
        if line.startswith("# ["):
            header_cited = cited
        else:
            assert cited or header_cited, f"{path.name}: no source for {line!r}"
