"""Print the Python requirements the image installs, from pyproject.toml, one per line.

    python3 requirements.py            # the light install: `[project] dependencies`
    python3 requirements.py all        # only what the extra `all` adds to it (its extras, resolved)

The Dockerfile installs them before the sources, so their layer is rebuilt only when
pyproject.toml changes. A bad extra name exits 2 naming it.
"""

from __future__ import annotations

import re
import sys
import tomllib

SELF = re.compile(r"^riverbridge\[(?P<extras>[^\]]+)\]$")


def extra_requirements(extras: dict[str, list[str]], name: str) -> list[str]:
    """The requirements of extra `name`, its `riverbridge[...]` references expanded."""
    if name not in extras:
        raise KeyError(name)
    found: list[str] = []
    for requirement in extras[name]:
        nested = SELF.match(requirement.replace(" ", ""))
        if nested is None:
            found.append(requirement)
            continue
        for inner in nested.group("extras").split(","):
            found += extra_requirements(extras, inner)
    return list(dict.fromkeys(found))


def main(argv: list[str]) -> int:
    with open("pyproject.toml", "rb") as file:
        project = tomllib.load(file)["project"]
    if not argv:
        print("\n".join(project["dependencies"]))
        return 0
    try:
        for name in argv:
            print("\n".join(extra_requirements(project["optional-dependencies"], name)))
    except KeyError as missing:
        print(f"requirements.py: no extra {missing} in pyproject.toml", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
