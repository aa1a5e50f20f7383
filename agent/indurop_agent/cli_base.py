"""cli_base.py -- what every part of irpctl (cli.py and its cli_*.py command groups) shares: the exit
codes and how a command's arguments are written (docs/irpctl.md)."""

from __future__ import annotations

# 0 done, 1 the API refused (4xx, 409), 2 usage, 3 the agent or irpd unreachable
EXIT_OK, EXIT_REFUSED, EXIT_USAGE, EXIT_UNREACHABLE = 0, 1, 2, 3


def arg(*flags: str, **kw) -> tuple[tuple[str, ...], dict]:
    """One argument of a command, as argparse's add_argument takes it."""
    return flags, kw
