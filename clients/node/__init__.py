"""What every node process of riverbridge runs on: the simulator, navigation, the recorder and
the player, and the supervisor that starts them.

A node's command line (:mod:`clients.node.cli`: options, signals, exit codes), its two
connections to the bridge with its telemetry (:mod:`clients.node.links`,
:mod:`clients.node.telemetry`), and one node run as a supervised child process
(:mod:`clients.node.child`, writing to :mod:`clients.node.output`). It builds only on the client
library; ``stack``, ``recording`` and ``report`` build on it, never the other way round.
"""
