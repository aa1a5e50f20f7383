"""base.py -- what every part of irpctl (irpctl.py and its command groups beside it) shares: the exit
codes, how a command's arguments are written, and the time filters' parser (docs/irpctl.md)."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta

# 0 done, 1 the API refused (4xx, 409), 2 usage, 3 the agent or irpd unreachable
EXIT_OK, EXIT_REFUSED, EXIT_USAGE, EXIT_UNREACHABLE = 0, 1, 2, 3


def arg(*flags: str, **kw) -> tuple[tuple[str, ...], dict]:
    """One argument of a command, as argparse's add_argument takes it."""
    return flags, kw


_AGO = re.compile(r"(\d+(?:\.\d*)?)\s*(s|m|min|h|d)")


def parse_time(text: str) -> str:
    """A time for the filters of the alarm history and of the logs (--since, --until): ISO 8601 (UTC
    without a zone), or how long ago (30m, 2h, 1d)."""
    ago = _AGO.fullmatch(text.strip())
    if ago:
        unit = {"s": 1, "m": 60, "min": 60, "h": 3600, "d": 86400}[ago.group(2)]
        t = datetime.now(UTC) - timedelta(seconds=float(ago.group(1)) * unit)
    else:
        try:
            t = datetime.fromisoformat(text.strip())
        except ValueError:
            raise ValueError(
                f"'{text}' is not a time: give ISO 8601 (2026-01-31T08:00, UTC without a zone) or how long ago (30m, 2h, 1d)"
            ) from None
        t = t if t.tzinfo else t.replace(tzinfo=UTC)
    return t.astimezone(UTC).isoformat().replace("+00:00", "Z")
