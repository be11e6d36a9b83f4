"""The supervisor's one output stream: every child's lines and its own log, ``[name]``-prefixed."""

from __future__ import annotations

import logging
from typing import TextIO

_COLOURS = {"bridge": "36", "sim": "32", "nav": "35", "up": "1"}  # ANSI: cyan, green, magenta


class PrefixedOutput:
    """Writes ``[name] line`` to one stream, flushed per line; ANSI colour only on a TTY."""

    def __init__(self, stream: TextIO, colour: bool | None = None) -> None:
        self._stream: TextIO | None = stream
        self._colour = stream.isatty() if colour is None else colour
        self._width = max(len(name) for name in _COLOURS) + 2

    def write(self, name: str, text: str) -> None:
        """Write one line. Once the stream is gone (``| head`` exited) lines are dropped, so
        the children's pipes keep draining and nothing blocks."""
        if self._stream is None:
            return
        prefix = f"[{name}]".ljust(self._width)
        if self._colour:
            prefix = f"\x1b[{_COLOURS.get(name, '0')}m{prefix}\x1b[0m"
        try:
            self._stream.write(f"{prefix} {text}\n")
            self._stream.flush()
        except (OSError, ValueError):  # BrokenPipeError; ValueError: the stream was closed
            self._stream = None


class PrefixedLogHandler(logging.Handler):
    """Sends log records (the supervisor's own) to a :class:`PrefixedOutput` as ``[up]``."""

    def __init__(self, output: PrefixedOutput, name: str = "up") -> None:
        super().__init__()
        self._output, self._label = output, name

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self._output.write(self._label, self.format(record))
        except Exception:  # logging must never raise into the caller
            self.handleError(record)
