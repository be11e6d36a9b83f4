"""A stand-in component that never handles SIGINT, so it dies of it (exit code -2)."""

import time

time.sleep(3600)
