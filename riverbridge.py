"""The ``riverbridge`` command: one entry point, one subcommand per process.

This module is the composition root: it is the only place that knows every part, and it
imports a part only when its subcommand runs, so ``riverbridge bridge`` never loads Embree
or scikit-learn.
"""

from __future__ import annotations

import importlib
import sys

# subcommand -> (module with ``main(argv) -> int``, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "bridge": ("bridge.cli", "run the rosbridge v2 websocket server"),
    "token": ("bridge.token_cli", "print a signed bridge token for a role (--roles)"),
    "sim": ("simulator.cli", "run the simulator (scene, vessel, sensors) against a bridge"),
    "nav": ("navigation.cli", "run the navigation service against a bridge"),
    "guide": ("guidance.cli", "run guidance and control (the autopilot) against a bridge"),
    "teleop": ("simulator.teleop_cli", "steer the simulated vessel from the keyboard"),
    "up": ("clients.stack.up_cli", "run bridge, simulator and navigation as three local processes"),
    "report": (
        "clients.report.cli",
        "measure latency and bytes per topic and stage, next to the thesis's figures",
    ),
    "record": ("clients.recording.record_cli", "record a bridge's topics into an MCAP file"),
    "play": (
        "clients.recording.play_cli",
        "publish an MCAP recording into a bridge at its recorded timing",
    ),
    "link": ("clients.linkemu.cli", "carry connections over an emulated lan, wifi or 4g link"),
}


# What the extras (pyproject `[project.optional-dependencies]`) add, and the extra each command
# needs: a light install (`pip install riverbridge`) runs the bridge, record and play, and a
# command that needs more says which extra to install instead of a traceback.
EXTRA_LIBRARIES = {"trimesh", "embreex", "cv2", "sklearn", "scipy", "matplotlib"}
EXTRA_OF_COMMAND = {"sim": "sim", "teleop": "sim", "nav": "nav", "up": "sim,nav", "report": "all"}


def _usage() -> str:
    lines = ["usage: riverbridge <command> [options]", "", "commands:"]
    lines += [f"  {name:<8} {help_text}" for name, (_, help_text) in SUBCOMMANDS.items()]
    lines += ["", "Run 'riverbridge <command> --help' for the options of a command."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in {"-h", "--help"}:
        print(_usage())
        return 0 if args else 2
    command, rest = args[0], args[1:]
    if command not in SUBCOMMANDS:
        print(f"riverbridge: unknown command {command!r}\n\n{_usage()}", file=sys.stderr)
        return 2
    try:
        module = importlib.import_module(SUBCOMMANDS[command][0])
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] not in EXTRA_LIBRARIES:
            raise
        extra = EXTRA_OF_COMMAND.get(command, "all")
        print(
            f"riverbridge {command} needs {exc.name}, which this install lacks: "
            f"pip install 'riverbridge[{extra}]'",
            file=sys.stderr,
        )
        return 2
    return int(module.main(rest))


if __name__ == "__main__":
    sys.exit(main())
