"""dds_imports.py -- the system alarm `dds/import:<variable>`: raised while an import of the running
set's dds.json is stale, cleared when it follows its source again (docs/alarms.md "System alarms",
docs/dds.md "Controllers sharing variables").

The agent does not ask the DDS bridge: it reads what a module would read.  When irpd's status
names another set (or generation, or irpd), the set's dds.json is read again for its imports; every
alarm poll each import's staleness flag is read from the variables segment (read-only, as the
agent reads any variable) and, when the import has a stamp_ns variable, the stamp's age on this
host's CLOCK_MONOTONIC.  An import is stale while its flag is set, or while its stamp is older than
its timeout_ms plus STAMP_SLACK_MS: then the bridge itself has stopped writing (it died), and
nothing clears the flag of a source that is gone.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from ..dds import bridge_file
from ..dds.bridge_file import BRIDGE_JSON, BridgeFileError
from ..dds.sharing import Import
from ..irpd.variables import Segment, VariableError
from .manager import SYSTEM, AlarmManager

MODULE = "dds"
SEVERITY = "high"
TEXT = "an imported variable is stale: it holds its fallback, its source controller is gone or silent"
STAMP_SLACK_MS = 1000  # beyond timeout_ms: the bridge writes the flag within its timeout, this is for its stalls


def alarm_id(imp: Import) -> str:
    return f"import:{imp.variable}"


class ImportAlarms:
    def __init__(
        self,
        manager: AlarmManager,
        clock: Callable[[], int] = time.time_ns,
        monotonic_ns: Callable[[], int] = time.monotonic_ns,
    ):
        self.manager, self.clock, self.monotonic_ns = manager, clock, monotonic_ns
        self.key: tuple | None = None
        self.imports: tuple[Import, ...] = ()
        self.segment: Segment | None = None
        self.segment_name: str | None = None
        self.problem: str | None = None  # why the imports are not watched (dds.json refused, no segment)

    def follow(self, status: dict) -> None:
        """irpd's status: the running set's imports, read again when the set changed."""
        self.segment_name = (status.get("shared_memory") or {}).get("variables")
        key = (status.get("pid"), status.get("set"), status.get("generation"))
        if key == self.key:
            return
        self.key = key
        self.imports, self.problem = (), None
        folder = Path(status.get("set") or "").parent
        if status.get("set") and (folder / BRIDGE_JSON).is_file():
            try:
                self.imports = bridge_file.parse((folder / BRIDGE_JSON).read_bytes()).imports
            except (BridgeFileError, OSError) as e:
                self.problem = str(e)
        ids = {alarm_id(imp) for imp in self.imports}
        with self.manager.batch():  # the alarms of imports the set no longer has
            for a in list(self.manager.alarms.values()):
                if a.origin == SYSTEM and a.module == MODULE and a.active and a.id not in ids:
                    self.manager.clear_alarm(MODULE, a.id, self.clock(), note="the running set no longer imports it")

    def open(self) -> Segment | None:
        seg = self.segment
        if seg is not None and not seg.replaced() and seg.path.name == (self.segment_name or "").lstrip("/"):
            return seg
        if seg is not None:
            seg.close()
        self.segment = None
        if self.segment_name:
            try:
                self.segment = Segment(self.segment_name)
            except VariableError as e:
                self.problem = str(e)
        return self.segment

    def stale(self, seg: Segment, imp: Import) -> str:
        """Why the import is stale ("" while it follows its source)."""
        if seg.read(imp.stale):
            return f"{imp.stale} is set: {imp.variable} holds its fallback"
        if imp.stamp_ns:
            stamp = seg.read(imp.stamp_ns)
            age_ms = (self.monotonic_ns() - stamp) / 1e6
            if stamp and age_ms > imp.timeout_ms + STAMP_SLACK_MS:
                return f"{imp.stamp_ns} is {age_ms / 1000:.1f} s old: the DDS bridge does not write it"
        return ""

    def poll(self) -> None:
        """Every alarm poll: raises or clears each import's alarm."""
        if not self.imports:
            return
        seg = self.open()
        if seg is None:
            return
        now = self.clock()
        with self.manager.batch():
            for imp in self.imports:
                try:
                    why = self.stale(seg, imp)
                except VariableError as e:  # not in the running layout: the bridge says so too
                    why = str(e)
                a = self.manager.alarms.get(f"{MODULE}/{alarm_id(imp)}")
                if why and (a is None or not a.active):
                    self.manager.raise_alarm(
                        MODULE,
                        alarm_id(imp),
                        now,
                        detail=f"the import of {imp.key}: {why}",
                        severity=SEVERITY,
                        text=TEXT,
                        origin=SYSTEM,
                    )
                elif not why and a is not None and a.active:
                    self.manager.clear_alarm(MODULE, alarm_id(imp), now, note=f"{imp.variable} follows {imp.key} again")

    def close(self) -> None:
        if self.segment is not None:
            self.segment.close()
            self.segment = None
