"""refusals.py -- the audit lines of refused requests that are not a mutation's own (a 401, a role
refusal, a CSRF refusal, a body refused by validation): who if known, the route, why, and from
which address, rate-limited per kind so that a flood cannot fill the disk.

Each kind has a bucket of BURST lines that refills by one every REFILL_S seconds; a refusal finding
its kind's bucket empty is counted, not written.  The next line of that kind that is written (or
the next read of the log, GET /audit) is preceded by one `refusals_suppressed` line saying how many
were left out since when.  So a sustained flood writes at most BURST lines and then two lines per
REFILL_S per kind: with 4 kinds, at most 4 x (30 + 2 x 1440) = 11,640 lines a day, each under
MAX_TEXT characters of route and of detail (about 1 KiB): under 12 MiB a day.  docs/security.md,
"What is logged"."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from .audit import AuditLog
from .auth import now_iso

KINDS = ("unauthenticated", "forbidden", "csrf", "invalid")
BURST = 30
REFILL_S = 60.0
MAX_TEXT = 256


def clipped(text: str) -> str:
    return text if len(text) <= MAX_TEXT else text[: MAX_TEXT - 1] + "…"


@dataclass
class Bucket:
    tokens: float
    at: float  # when tokens was last refilled
    suppressed: int = 0
    since: str | None = None  # when the first suppressed refusal came


class RefusalAudit:
    def __init__(self, audit: AuditLog, burst: int = BURST, refill_s: float = REFILL_S, clock=time.monotonic):
        self.audit, self.burst, self.refill_s, self.clock = audit, burst, refill_s, clock
        self._lock = threading.Lock()
        self._buckets = {kind: Bucket(float(burst), clock()) for kind in KINDS}

    def write(self, kind: str, *, who: dict | None, client: str, route: str, status: int, detail) -> bool:
        """One refusal of `kind` (KINDS); whether its line was written (False: suppressed)."""
        with self._lock:
            bucket = self._buckets[kind]
            now = self.clock()
            bucket.tokens = min(self.burst, bucket.tokens + (now - bucket.at) / self.refill_s)
            bucket.at = now
            if bucket.tokens < 1:
                bucket.suppressed += 1
                bucket.since = bucket.since or now_iso()
                return False
            bucket.tokens -= 1
            self._summary(kind, bucket)
        text = detail if isinstance(detail, str) else "; ".join(f"{p.get('loc')}: {p.get('msg')}" for p in detail)
        self.audit.write(
            "refused",
            who=who,
            client=client,
            target=clipped(route),
            result="error",
            status=status,
            kind=kind,
            detail=clipped(text),
        )
        return True

    def flush(self) -> None:
        """Writes the pending `refusals_suppressed` lines (before the log is read)."""
        with self._lock:
            for kind, bucket in self._buckets.items():
                self._summary(kind, bucket)

    def _summary(self, kind: str, bucket: Bucket) -> None:
        if bucket.suppressed:
            n, since = bucket.suppressed, bucket.since
            bucket.suppressed, bucket.since = 0, None
            self.audit.write(
                "refusals_suppressed",
                who=None,
                client=None,
                target=kind,
                result="error",
                suppressed=n,
                since=since,
                detail=f"{n} refusals ({kind}) suppressed since {since}: at most {self.burst} lines at once, "
                f"then one every {self.refill_s:g} s per kind",
            )
