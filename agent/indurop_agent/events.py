"""events.py -- the agent's own events (uploads, activations, restores, token changes, irpd lost or
back), kept in memory with sequence numbers in the shape of irpd's `events`, so that GET /events
can merge both streams by time.  The audit log is the durable record; this is the live feed."""

from __future__ import annotations

import threading
import time
from collections import deque

from .access.auth import now_iso


class AgentEvents:
    def __init__(self, capacity: int = 1000):
        self._events: deque[dict] = deque(maxlen=capacity)
        self._next = 1
        self._lock = threading.Lock()

    def add(self, kind: str, message: str, *, module: str | None = None, set_id: str | None = None) -> dict:
        with self._lock:
            event = {
                "seq": self._next,
                "time": now_iso(),
                "time_ns": time.time_ns(),
                "kind": kind,
                "module": module,
                "message": message,
            }
            if set_id is not None:
                event["set_id"] = set_id
            self._next += 1
            self._events.append(event)
            return event

    def since(self, seq: int, limit: int) -> dict:
        """Events with seq >= `seq` (at most `limit`): {"next", "dropped", "events"} like irpd's."""
        with self._lock:
            events = [e for e in self._events if e["seq"] >= seq][:limit]
            oldest = self._events[0]["seq"] if self._events else self._next
            dropped = max(0, oldest - max(seq, 1))  # asked for, but already pushed out of the ring
            return {"next": events[-1]["seq"] + 1 if events else self._next, "dropped": dropped, "events": events}
