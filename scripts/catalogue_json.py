"""Write web/src/catalogue.json, the dashboard's copy of the topic catalogue (schemas/catalogue.py).

    python3 scripts/catalogue_json.py            # rewrite the file
    python3 scripts/catalogue_json.py --check    # exit 1 if the file differs

The dashboard is built by Vite without Python, so it reads the catalogue from this committed
file; tests/test_catalogue.py fails while the two differ.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from schemas.catalogue import as_data  # noqa: E402

TARGET = ROOT / "web" / "src" / "catalogue.json"


def render() -> str:
    return json.dumps(as_data(), indent=1) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only compare, exit 1 if stale")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        current = TARGET.read_text(encoding="utf-8") if TARGET.exists() else ""
        if current != text:
            print(
                f"{TARGET.relative_to(ROOT)} is stale: run python3 scripts/catalogue_json.py",
                file=sys.stderr,
            )
            return 1
        return 0
    TARGET.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
