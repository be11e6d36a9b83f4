# One image for the three riverbridge services (bridge, simulator, navigation); see
# docker-compose.yml. Every dependency ships manylinux wheels (numpy, Embree via embreex,
# OpenCV headless, scikit-learn), so the slim image needs no compiler and no X libraries.
FROM python:3.11-slim

# Unbuffered logs; glibc malloc tuned for 4 MB sensor buffers (fresh mmap'd buffers cost ~3 ms
# of page faults per scan, see performance-measurements.md): the same environment
# `riverbridge up` gives its children (clients/launcher.py, MALLOC_ENV).
ENV PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    MALLOC_MMAP_THRESHOLD_=268435456 \
    MALLOC_TRIM_THRESHOLD_=1073741824 \
    MALLOC_TOP_PAD_=67108864

WORKDIR /build
COPY pyproject.toml README.md riverbridge.py ./
COPY schemas ./schemas
COPY bridge ./bridge
COPY clients ./clients
COPY simulator ./simulator
COPY navigation ./navigation
RUN pip install . && rm -rf /build

# Default configuration; docker-compose.yml mounts ./config over it.
COPY config /config

RUN useradd --system --no-create-home --shell /usr/sbin/nologin riverbridge
USER riverbridge
WORKDIR /tmp

EXPOSE 9090
CMD ["python", "-m", "bridge", "--host", "0.0.0.0", "--port", "9090"]
