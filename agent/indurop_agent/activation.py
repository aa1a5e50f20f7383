"""activation.py -- putting a stored set into irpd: activate, rollback, and the restore watcher.

Activating sends irpd `load` {config: <data>/sets/<id>/files/module.xml, set_id: <id>} (a hot
swap, up to 30 s) and only when irpd took it records the history and the active set; a refusal
changes nothing.  The watcher polls irpd's `status`: whenever the agent (re)connects to an irpd
(at start, after irpd was unreachable, or to a new irpd process) whose set_id is not the store's
active set, it activates the active set again, so a restarted irpd comes back with the set the
operator chose.  It never raises: irpd may be absent for as long as it likes.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

from .audit import AuditLog
from .errors import problems
from .events import AgentEvents
from .irpd_client import IrpdClient, IrpdRefused, IrpdUnavailable
from .store import SetStore, StoreError

AGENT = {"id": None, "name": "indurop-agent", "role": None}  # who a restore is done by


class Activator:
    def __init__(self, store: SetStore, irpd: IrpdClient, events: AgentEvents, swap_timeout_s: float = 30.0):
        self.store, self.irpd, self.events, self.swap_timeout_s = store, irpd, events, swap_timeout_s
        self._lock = threading.Lock()  # one activation at a time, and rollback's target stays put

    def activate(self, set_id: str, who: dict | None, action: str = "activate") -> dict:
        """Loads the set into irpd and records it; returns irpd's swap report.  Raises StoreError
        (unknown set), IrpdRefused (irpd kept its set) or IrpdUnavailable."""
        with self._lock:
            return self._activate_locked(set_id, who, action)

    def rollback(self, who: dict | None) -> tuple[str, dict]:
        """Activates the set that was active before the current one: (its id, the swap report)."""
        with self._lock:
            target = self.store.rollback_target()
            if target is None:
                current = self.store.active_id()
                raise StoreError(f"no set was active before {current}; nothing to roll back to" if current else
                                 "no set has been activated yet; nothing to roll back to", status=409)
            return target, self._activate_locked(target, who, "rollback")

    def _activate_locked(self, set_id: str, who: dict | None, action: str) -> dict:
        if self.store.manifest(set_id) is None:
            raise StoreError(f"no set {set_id}; GET /api/v1/sets lists them", status=404)
        config = str(self.store.module_xml(set_id))
        report = self.irpd.request("load", config=config, set_id=set_id, timeout=self.swap_timeout_s)
        self.store.record_activation(set_id, action, who, report)
        generation = (report or {}).get("generation")
        self.events.add(action, f"set {set_id} is active (generation {generation}, "
                                f"missed periods {(report or {}).get('missed_periods')})", set_id=set_id)
        return report


class Restorer(threading.Thread):
    """The watcher: polls irpd's status every `poll_s` on a connection of its own; when irpd is
    new (restarted) and runs another set than the store's active one, loads the active one."""

    RETRY_FIRST_S = 2.0
    RETRY_MAX_S = 60.0

    def __init__(self, activator: Activator, socket_path: str, events: AgentEvents, audit: AuditLog,
                 poll_s: float = 1.0):
        super().__init__(name="irpd-restorer", daemon=True)
        self.activator, self.events, self.audit, self.poll_s = activator, events, audit, poll_s
        self.client = IrpdClient(socket_path, timeout_s=2.0)
        self._stop_event = threading.Event()
        self.reachable: bool | None = None
        self.irpd_pid = None
        # A restore that failed (irpd still starting, a swap that timed out on a loaded machine) is
        # tried again while irpd runs another set: after RETRY_FIRST_S, doubling up to RETRY_MAX_S.
        self.retry_at: float | None = None
        self.retry_s = self.RETRY_FIRST_S

    def stop(self) -> None:
        self._stop_event.set()
        self.join(timeout=5)
        self.client.close()

    def run(self) -> None:
        wait = 0.0
        while not self._stop_event.wait(wait):
            wait = self.poll_s
            try:
                self.poll_once()
            except Exception as e:  # noqa: BLE001 -- the watcher must outlive anything irpd does
                self.events.add("agent_error", f"the restore watcher: {type(e).__name__}: {e}")

    def poll_once(self) -> None:
        try:
            status = self.client.request("status")
        except (IrpdUnavailable, IrpdRefused) as e:
            if self.reachable:
                self.events.add("irpd_lost", f"irpd stopped answering: {e}")
            self.reachable = False
            return
        pid = status.get("pid")
        if self.reachable and pid == self.irpd_pid:
            if self.retry_at is not None and time.monotonic() >= self.retry_at:
                self.restore(status)
            return
        came_back = self.reachable is False or self.irpd_pid is not None
        self.reachable, self.irpd_pid = True, pid
        self.events.add("irpd_connected", f"irpd (pid {pid}) answers{' again' if came_back else ''}; "
                                          f"running set {status.get('set_id')}")
        self.restore(status)

    def restore(self, status: dict) -> None:
        active = self.activator.store.active_id()
        if active is None or status.get("set_id") == active:
            self.retry_at, self.retry_s = None, self.RETRY_FIRST_S
            return
        try:
            report = self.activator.activate(active, AGENT, "restore")
        except (StoreError, IrpdRefused, IrpdUnavailable) as e:
            self.events.add("restore_failed", f"could not restore set {active}: {e}; trying again in "
                                              f"{self.retry_s:g} s", set_id=active)
            self.audit.write("restore", who=AGENT, client=None, target=active, result="error", detail=str(e))
            self.retry_at = time.monotonic() + self.retry_s
            self.retry_s = min(2 * self.retry_s, self.RETRY_MAX_S)
            return
        self.retry_at, self.retry_s = None, self.RETRY_FIRST_S
        self.audit.write("restore", who=AGENT, client=None, target=active, result="ok",
                         generation=(report or {}).get("generation"),
                         replaced=status.get("set_id"))


def irpd_validation(irpd: IrpdClient, module_xml, timeout_s: float = 30.0) -> dict:
    """irpd's `check` of a stored set, as the manifest's validation report, each error also as a
    problem saying where it points in the set.  irpd unreachable (or too old to check): stored
    unchecked, valid null, and a warning that says so."""
    unchecked = {"valid": None, "errors": [], "problems": [], "schedule": None}
    try:
        result = irpd.request("check", config=str(module_xml), timeout=timeout_s) or {}
    except IrpdUnavailable:
        return {**unchecked, "warnings": ["not checked: irpd unreachable"]}
    except IrpdRefused as e:
        return {**unchecked, "warnings": [f"not checked: irpd cannot check sets ({e})"]}
    errors = [str(x) for x in result.get("errors") or []]
    return {"valid": bool(result.get("valid")), "errors": errors,
            "problems": problems(errors, Path(module_xml).parent),
            "warnings": [str(x) for x in result.get("warnings") or []], "schedule": result.get("schedule"),
            "online": result.get("online"), "restart": result.get("restart"), "variables": result.get("variables")}
