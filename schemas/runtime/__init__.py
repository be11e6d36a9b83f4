"""What every riverbridge process does to itself at run time, apart from the message layer.

`schemas` is the bottom layer both the bridge and the client side build on, but its message
modules (types, ops, codecs, tracing data) do no I/O. The few process-level helpers that the
bridge, the simulator and the navigation service share live here instead, in a room of their
own that the message layer never imports (tests/test_architecture.py):

- :mod:`schemas.runtime.process`: start-up tuning (BLAS threads, GIL switch interval, frozen
  start-up heap) and background priority for heavy worker threads.
- :mod:`schemas.runtime.telemetry`: the process's own CPU and memory, its identity (name, pid,
  host) and the telemetry rhythm the bridge and the clients share.
- :mod:`schemas.runtime.native`: whether the compiled hot path (mypyc, `build/native/`) runs
  in place of the sources; the packages' `__init__` ask it, schemas' own included.
"""
