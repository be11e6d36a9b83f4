"""Tests of `riverbridge up`, the health check and the docker compose files."""
