#!/usr/bin/env bash
# Installs everything riverbridge and its tests need on a fresh machine: the Python package with
# its test extra, and Node.js + the npm packages of the real-client compatibility tests.
set -euo pipefail
cd "$(dirname "$0")/.."

python3 -m pip install --quiet --disable-pip-version-check -e '.[test]'

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "setup: installing Node.js and npm from Debian's packages" >&2
    apt-get update -qq && apt-get install -y -qq nodejs npm >/dev/null
fi
if [ -f tests/compat/js/package-lock.json ]; then
    npm ci --prefix tests/compat/js --no-audit --no-fund --loglevel=error
fi
