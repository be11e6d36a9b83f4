"""The dashboard's topic list is the catalogue: web/src/catalogue.json is schemas.catalogue, and
the page's sources name topics only by catalogue key (no browser needed)."""

from __future__ import annotations

import json
import re
import subprocess
import sys

from schemas.catalogue import TOPICS, as_data, consumed_by

from .stack import REPO_ROOT

WEB_SRC = REPO_ROOT / "web" / "src"
TOPIC_KEY = re.compile(r"""\btopic\(["'](\w+)["']\)""")
HTTP_PATHS = {"/metrics"}  # the bridge's HTTP routes the page fetches: not topics
TOPIC_NAME = re.compile(r"""["'`](/[a-z_]+(?:/[a-z_]+)*)["'`]""")


def sources() -> dict[str, str]:
    return {
        str(path.relative_to(WEB_SRC)): path.read_text(encoding="utf-8")
        for path in sorted(WEB_SRC.rglob("*.js"))
    }


def test_the_web_copy_is_the_catalogue():
    """Rewrite it with `python3 scripts/catalogue_json.py` after changing the catalogue."""
    copy = json.loads((WEB_SRC / "catalogue.json").read_text(encoding="utf-8"))
    assert copy == as_data(), "web/src/catalogue.json is stale: run scripts/catalogue_json.py"
    check = subprocess.run(
        [sys.executable, str(REPO_ROOT / "scripts" / "catalogue_json.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert check.returncode == 0, check.stderr


def test_the_page_names_topics_only_by_catalogue_key():
    used: set[str] = set()
    for name, text in sources().items():
        used |= set(TOPIC_KEY.findall(text))
        spelled = [t for t in TOPIC_NAME.findall(text) if not t.startswith("/rosapi/")]
        spelled = [t for t in spelled if t not in HTTP_PATHS]
        assert not spelled, f"{name} spells topic names {spelled}: use topic(key)"
    assert used <= set(TOPICS), sorted(used - set(TOPICS))


def test_the_page_throttles_every_topic_it_subscribes_to():
    """main.js subscribes to the catalogue's dashboard topics (the LIDAR through its worker),
    each at the throttle THROTTLE_MS gives it."""
    main = sources()["main.js"]
    block = re.search(r"const THROTTLE_MS = \{(.*?)\};", main, re.S)
    assert block, "main.js has no THROTTLE_MS"
    throttled = set(re.findall(r"(\w+):", block.group(1)))
    assert throttled == {t.key for t in consumed_by("dashboard")} - {"lidar"}
