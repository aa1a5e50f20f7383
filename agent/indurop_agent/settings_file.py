"""settings_file.py -- the settings of the agent's side processes (the DDS bridge, the OPC UA
server): a dataclass's fields from a `--config` JSON file, then the command line's options that were
given, each named as its field.  The caller converts and checks the values."""

from __future__ import annotations

import argparse
import dataclasses
import json


def settings_values(ap: argparse.ArgumentParser, args: argparse.Namespace, cls: type) -> dict:
    """The values for `cls(**values)`: --config's object (unknown names refused, naming the known
    ones), overridden by each option not None."""
    values: dict = {}
    if args.config:
        try:
            values = json.loads(args.config.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            ap.error(f"--config {args.config}: {e}")
        if not isinstance(values, dict):
            ap.error(f"--config {args.config}: expected a JSON object of settings")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            ap.error(f"--config {args.config}: unknown setting {unknown[0]!r}; known: {', '.join(sorted(known))}")
    for f in dataclasses.fields(cls):
        v = getattr(args, f.name, None)
        if v is not None:
            values[f.name] = v
    return values
