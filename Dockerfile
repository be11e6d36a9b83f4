# One image for the three riverbridge services (bridge, simulator, navigation) and the web
# dashboard the bridge serves; see docker-compose.yml. Every Python dependency ships manylinux
# wheels (numpy, Embree via embreex, OpenCV headless, scikit-learn), so no compiler is needed.
# The default (last) stage is that full stack; `--target bridge` builds the bridge alone (the
# light install: bridge, client library, record/play and the dashboard, no simulator or
# navigation libraries):
#   docker build -t riverbridge .                          # the whole stack (docker-compose.yml)
#   docker build --target bridge -t riverbridge-bridge .   # the bridge only
#
# Both bases are arguments, so the image also builds where no image registry is reachable
# (tests/launcher/test_compose_engine.py builds them from Debian's packages):
#   BASE_IMAGE  a Debian-like image with python3 (>= 3.11) and its venv module
#   NODE_IMAGE  an image with Node.js >= 20.19 and npm, for the dashboard build only
# Network settings the build needs (a package index, an npm registry, a CA bundle) go into
# docker/build-config/ (see the README there): only the build stages read them, the final
# image has none of them.
ARG BASE_IMAGE=python:3.11-slim
ARG NODE_IMAGE=node:22-bookworm-slim

# -- the dashboard: web/ built with npm into /web/dist ---------------------------------------
FROM ${NODE_IMAGE} AS dashboard
WORKDIR /web
COPY docker/build-config/ /build-config/
COPY web/package.json web/package-lock.json ./
RUN if [ -f /build-config/npmrc ]; then export NPM_CONFIG_USERCONFIG=/build-config/npmrc; fi; \
    if [ -f /build-config/ca-certificates.crt ]; then \
        export NODE_EXTRA_CA_CERTS=/build-config/ca-certificates.crt; fi; \
    npm ci --no-audit --no-fund --loglevel=error
COPY web/ ./
RUN npm run build

# -- the light install in a virtual environment at /opt/riverbridge: bridge, clients, schemas --
FROM ${BASE_IMAGE} AS install-bridge
ENV PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1
COPY docker/build-config/ /build-config/
RUN python3 -m venv /opt/riverbridge
WORKDIR /build
# The dependencies first, in their own layer: it is rebuilt only when pyproject.toml changes.
# docker/requirements.py lists them from pyproject.toml (the base, or the base with extras).
COPY pyproject.toml docker/requirements.py ./
RUN if [ -f /build-config/pip.conf ]; then export PIP_CONFIG_FILE=/build-config/pip.conf; fi; \
    python3 requirements.py > requirements.txt \
    && /opt/riverbridge/bin/pip install --quiet -r requirements.txt
COPY README.md riverbridge.py ./
COPY schemas ./schemas
COPY bridge ./bridge
COPY clients ./clients
RUN if [ -f /build-config/pip.conf ]; then export PIP_CONFIG_FILE=/build-config/pip.conf; fi; \
    /opt/riverbridge/bin/pip install --quiet --no-deps .

# -- the whole package: the light install plus the simulator's, navigation's, report's extras --
FROM install-bridge AS install
RUN if [ -f /build-config/pip.conf ]; then export PIP_CONFIG_FILE=/build-config/pip.conf; fi; \
    python3 requirements.py all > requirements-all.txt \
    && /opt/riverbridge/bin/pip install --quiet -r requirements-all.txt
COPY simulator ./simulator
COPY navigation ./navigation
RUN if [ -f /build-config/pip.conf ]; then export PIP_CONFIG_FILE=/build-config/pip.conf; fi; \
    /opt/riverbridge/bin/pip install --quiet --no-deps .

# -- what both images share: the environment and a non-root user -----------------------------
FROM ${BASE_IMAGE} AS runtime

# Unbuffered logs; glibc malloc tuned for 4 MB sensor buffers (fresh mmap'd buffers cost ~3 ms
# of page faults per scan, see performance-measurements.md): the same environment
# `riverbridge up` gives its children (schemas/runtime/process.py, MALLOC_ENV).
ENV PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1 \
    MALLOC_MMAP_THRESHOLD_=268435456 \
    MALLOC_TRIM_THRESHOLD_=1073741824 \
    MALLOC_TOP_PAD_=67108864 \
    PATH=/opt/riverbridge/bin:$PATH \
    RIVERBRIDGE_WEB_ROOT=/opt/riverbridge/web
RUN useradd --system --no-create-home --shell /usr/sbin/nologin riverbridge
WORKDIR /tmp
EXPOSE 9090

# -- `--target bridge`: the bridge alone, with the dashboard it serves ------------------------
FROM runtime AS bridge
COPY --from=install-bridge /opt/riverbridge /opt/riverbridge
COPY --from=dashboard /web/dist /opt/riverbridge/web
USER riverbridge
CMD ["python", "-m", "bridge", "--host", "0.0.0.0", "--port", "9090"]

# -- the default image: the whole stack, the dashboard, the default configuration -------------
FROM runtime
COPY --from=install /opt/riverbridge /opt/riverbridge
COPY --from=dashboard /web/dist /opt/riverbridge/web
# Default configuration; docker-compose.yml mounts ./config over it.
COPY config /config
USER riverbridge
CMD ["python", "-m", "bridge", "--host", "0.0.0.0", "--port", "9090"]
