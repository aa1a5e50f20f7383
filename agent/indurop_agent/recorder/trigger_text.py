"""trigger_text.py -- a capture's trigger in words, for irpctl and the notes of a shot's file (no
dependencies: irpctl imports it)."""

from __future__ import annotations


def describe_trigger(t: dict) -> str:
    """A trigger in words: `SIG.wave[4] rising 0 and SIG.sample > 10`, `alarm (main/8)`."""
    if t["kind"] != "condition":
        extra = [x for x in (t.get("key"), t.get("severity") and f">= {t['severity']}") if x]
        return t["kind"] + (f" ({', '.join(extra)})" if extra else "")
    words = []
    for c in t["conditions"]:
        if c["kind"] == "edge":
            words.append(f"{c['variable']} {c['direction']} {c['threshold']:g}")
        elif c["kind"] == "level":
            words.append(f"{c['variable']} {c['compare']} {c['value']:g}")
        else:
            words.append(f"{c['variable']} {c['where']} [{c['low']:g}, {c['high']:g}]")
        if c.get("hold_rows", 1) > 1:
            words[-1] += f" for {c['hold_rows']}"
    return f" {t.get('combine', 'and')} ".join(words)
