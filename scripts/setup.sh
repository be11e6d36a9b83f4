#!/usr/bin/env bash
# Installs everything riverbridge and its tests need on a fresh machine: the Python package with
# its test extra, and Node.js + the npm packages of the real-client compatibility tests.
set -euo pipefail
cd "$(dirname "$0")/.."

python3 -m pip install --quiet --disable-pip-version-check -e '.[all,test]'

# The relay's hot path compiled with mypyc into build/native/ (schemas/runtime/native.py; ~2 min
# the first time, in the background while the rest installs; nothing while the sources are
# unchanged). Without it the same modules run as Python, slower: a failed build is reported and
# set-up goes on.
native_log="$(mktemp)"
python3 scripts/build_native.py >"$native_log" 2>&1 &
native_build=$!

# Debian packages: Node.js for the roslibjs tests and the dashboard build, Chromium for the
# dashboard's browser tests, docker-compose to validate and run docker-compose.yml, and the
# Docker engine (docker.io: dockerd, which tests/launcher/test_compose_engine.py starts when
# none runs) with debootstrap to build the image's base from Debian's packages.
missing=()
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
command -v docker-compose >/dev/null 2>&1 || missing+=(docker-compose)
command -v dockerd >/dev/null 2>&1 || missing+=(docker.io)
command -v debootstrap >/dev/null 2>&1 || missing+=(debootstrap)
# Debian's Chromium for the dashboard's browser tests (playwright-core drives it; no downloads)
[ -x /usr/bin/chromium ] || missing+=(chromium)
# iproute2: `ip` makes the two network namespaces of the DDS two-host test (tests/dds), `ss`
# reads the kernel's byte counters of the stack's sockets for the report
{ command -v ip && command -v ss; } >/dev/null 2>&1 || missing+=(iproute2)
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing ${missing[*]} from Debian's packages" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if [ -f tests/compat/js/package-lock.json ]; then
    npm ci --prefix tests/compat/js --no-audit --no-fund --loglevel=error
fi
# The web dashboard the bridge serves (web/dist), and playwright-core for its browser tests.
npm ci --prefix web --no-audit --no-fund --loglevel=error >/dev/null
npm run build --prefix web --silent >/dev/null

# Real ROS 2 nodes for tests/dds/test_dds_rclpy.py: rclpy from PyPI's ros-<distro>-* wheels
# (Python 3.12, rmw_fastrtps_cpp), one venv per distribution outside the checkout so that every
# clone shares them; made once (~40 s and ~260 MB each), skipped when the package list matches.
ros2_venvs="${RIVERBRIDGE_ROS2_VENVS:-$HOME/.cache/riverbridge}"
python312=""
for candidate in python3.12 "$(pyenv root 2>/dev/null || echo /root/.pyenv)"/versions/3.12*/bin/python3.12; do
    if "$candidate" -c 'import sys; assert sys.version_info[:2] == (3, 12)' >/dev/null 2>&1; then
        python312="$candidate"
        break
    fi
done
if [ -z "$python312" ]; then
    echo "setup: no Python 3.12 found; the ROS 2 venvs of tests/dds are not made" >&2
    exit 1
fi
for distro in jazzy kilted; do
    venv="$ros2_venvs/ros2-$distro"
    packages="ros-$distro-rclpy[fastrtps] ros-$distro-std-msgs ros-$distro-sensor-msgs"
    packages+=" ros-$distro-geometry-msgs ros-$distro-std-srvs ros-$distro-test-msgs"
    if [ "$(cat "$venv/.riverbridge-packages" 2>/dev/null)" = "$packages" ]; then
        continue
    fi
    echo "setup: making the ROS 2 $distro venv in $venv" >&2
    rm -rf "$venv"
    "$python312" -m venv "$venv"
    # shellcheck disable=SC2086  # the list is words
    "$venv/bin/pip" install --quiet --disable-pip-version-check $packages 2>&1 \
        | { grep -v "is ignored: it is neither a file nor a directory" || true; } >&2
    echo "$packages" > "$venv/.riverbridge-packages"
done

if ! wait "$native_build"; then
    cat "$native_log" >&2
    echo "setup: the compiled hot path was not built; the bridge runs its Python modules" >&2
else
    cat "$native_log"
fi
rm -f "$native_log"
