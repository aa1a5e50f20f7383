"""activation.py -- putting a stored set into irpd: activate, rollback, and the restore watcher.

Activating has a mode (docs/set-store.md).  `online` (the default) sends irpd `load` {config:
<data>/sets/<id>/files/module.xml, set_id: <id>} (a hot swap, up to 30 s); a set irpd can only run
after a restart is refused (409, RestartRequired).  `restart` sends irpd `restart` and waits until
the same irpd process answers again from its new image (up to the swap timeout plus the expected
downtime); `auto` restarts only when irpd's `check` says the set cannot go online.  Only when irpd
runs the set does the agent record the history and the active set; a refusal, or a restart after
which irpd came back on its old set, changes nothing.

The watcher polls irpd's `status`: whenever the agent (re)connects to an irpd (at start, after irpd
was unreachable, or to a new irpd process) whose set_id is not the store's active set, it activates
the active set again (online), so a restarted irpd comes back with the set the operator chose.  It
never raises: irpd may be absent for as long as it likes.  It does not look while an activation
runs (a managed restart makes irpd unreachable for a while and then run a set the store records
only afterwards), and decides a restore under the activation lock, on a fresh status.
"""

from __future__ import annotations

import threading
import time
from contextlib import contextmanager
from pathlib import Path

from ..access.audit import AuditLog
from ..events import AgentEvents
from ..irpd import protocol
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from .errors import problems
from .store import SetStore, StoreError

AGENT = {"id": None, "name": "indurop-agent", "role": None}  # who a restore is done by
MODES = ("online", "restart", "auto")


class RestartRequired(IrpdRefused):
    """An online activation of a set irpd can run only after a restart."""


class RestartFellBack(IrpdRefused):
    """irpd restarted but could not start the set, and came back on the one it ran."""


class Activator:
    def __init__(self, store: SetStore, irpd: IrpdClient, events: AgentEvents, swap_timeout_s: float = 30.0):
        self.store, self.irpd, self.events, self.swap_timeout_s = store, irpd, events, swap_timeout_s
        self._lock = threading.Lock()  # one activation at a time, and rollback's target stays put

    def busy(self) -> bool:
        """True while an activation (or rollback, or restore) runs."""
        return self._lock.locked()

    @contextmanager
    def exclusive(self):
        """No activation (nor rollback, restore or restart) runs while the block does: the set
        store's pruning and a backup's restore hold it, so that irpd never loads a set they touch."""
        with self._lock:
            yield

    def restart_irpd(self) -> dict:
        """irpd's managed restart onto the active set (safe outputs first, same pid), or, before any
        set was activated, onto the module.xml it runs.  Nothing is recorded in the set store: the
        active set does not change.  Returns the restart's report ({"mode": "restart", "downtime_ns",
        "pid", "set_id", ...}); raises IrpdRefused (RestartFellBack: irpd came back on its old set)
        or IrpdUnavailable."""
        with self._lock:
            set_id = self.store.active_id()
            if set_id is not None:
                config = str(self.store.module_xml(set_id))
            else:
                status = self.irpd.request("status", timeout=self.swap_timeout_s) or {}
                config, set_id = status.get("set"), status.get("set_id")
                if not config:
                    raise IrpdRefused(
                        protocol.REFUSED, "irpd does not say which module.xml it runs; activate a set first"
                    )
            report = self._restart(config, set_id)
            self.events.add(
                "irpd_restart",
                f"irpd restarted onto set {set_id or config} (pid {report.get('pid')}, downtime "
                f"{(report.get('downtime_ns') or 0) / 1e6:.1f} ms)",
                set_id=set_id,
            )
            return report

    def activate(self, set_id: str, who: dict | None, action: str = "activate", mode: str = "online") -> dict:
        """Puts the set into irpd (mode online, restart or auto) and records it; returns irpd's swap
        report, or for a restart the report of the new image ({"mode": "restart", "downtime_ns", ...}).
        Raises StoreError (unknown set), IrpdRefused (irpd kept its set: RestartRequired,
        RestartFellBack) or IrpdUnavailable."""
        with self._lock:
            return self._activate_locked(set_id, who, action, mode)

    def rollback(self, who: dict | None, mode: str = "online") -> tuple[str, dict]:
        """Activates the set that was active before the current one: (its id, the swap report)."""
        with self._lock:
            target = self.store.rollback_target()
            if target is None:
                current = self.store.active_id()
                raise StoreError(
                    f"no set was active before {current}; nothing to roll back to"
                    if current
                    else "no set has been activated yet; nothing to roll back to",
                    status=409,
                )
            return target, self._activate_locked(target, who, "rollback", mode)

    def restore(self) -> tuple[str | None, str, dict] | None:
        """The store's active set into irpd (online) when irpd runs another one, decided on a fresh
        status under the activation lock: (irpd's set before, the set, the report), or None when
        there was nothing to do."""
        with self._lock:
            active = self.store.active_id()
            if active is None:
                return None
            running = (self.irpd.request("status", timeout=self.swap_timeout_s) or {}).get("set_id")
            if running == active:
                return None
            return running, active, self._activate_locked(active, AGENT, "restore", "online")

    def _activate_locked(self, set_id: str, who: dict | None, action: str, mode: str) -> dict:
        if mode not in MODES:
            raise StoreError(f"mode {mode!r}: expected one of {', '.join(MODES)}", status=422)
        if self.store.manifest(set_id) is None:
            raise StoreError(f"no set {set_id}; GET /api/v1/sets lists them", status=404)
        config = str(self.store.module_xml(set_id))
        if mode == "auto":
            checked = self.irpd.request("check", config=config, timeout=self.swap_timeout_s) or {}
            mode = "restart" if checked.get("valid") and checked.get("online") is False else "online"
        if mode == "restart":
            report = self._restart(config, set_id)
            action = "restart" if action == "activate" else action  # a rollback stays one (the stack pops)
        else:
            report = {**(self._load(config, set_id) or {}), "mode": "online"}
        self.store.record_activation(set_id, action, who, report)
        generation = report.get("generation")
        if mode == "restart":
            self.events.add(
                action,
                f"set {set_id} is active after a restart of irpd (pid {report.get('pid')}, "
                f"downtime {report['downtime_ns'] / 1e6:.1f} ms)",
                set_id=set_id,
            )
        else:
            self.events.add(
                action,
                f"set {set_id} is active (generation {generation}, missed periods {report.get('missed_periods')})",
                set_id=set_id,
            )
        return report

    def _load(self, config: str, set_id: str) -> dict:
        try:
            return self.irpd.request("load", config=config, set_id=set_id, timeout=self.swap_timeout_s)
        except IrpdRefused as e:
            if e.code != protocol.RESTART_REQUIRED:
                raise
            expected = ""
            try:
                restart = (self.irpd.request("check", config=config, timeout=self.swap_timeout_s) or {}).get("restart")
                if restart and restart.get("expected_downtime_ns") is not None:
                    expected = f", expected downtime about {restart['expected_downtime_ns'] / 1e6:.0f} ms"
            except (IrpdRefused, IrpdUnavailable):
                pass
            raise RestartRequired(
                e.code,
                f"set {set_id} cannot go online: {e}; activating it with mode restart "
                f"(or auto) restarts irpd onto it{expected}",
                e.error,
            ) from e

    def _restart(self, config: str, set_id: str | None) -> dict:
        """irpd's managed restart onto the set; waits for the new image (the same pid) to say it ran
        this request's restart (status.last_restart.requested_ns)."""
        named = {"set_id": set_id} if set_id is not None else {}  # a set irpd runs without an id keeps none
        asked = self.irpd.request("restart", config=config, timeout=self.swap_timeout_s, **named) or {}
        requested, pid = asked.get("requested_ns"), asked.get("pid")
        limit = self.swap_timeout_s + (asked.get("expected_downtime_ns") or 0) / 1e9
        deadline = time.monotonic() + limit
        while True:
            try:
                status = self.irpd.request("status", timeout=2.0) or {}
            except (IrpdUnavailable, IrpdRefused):
                status = {}
            last = status.get("last_restart") or {}
            if status and status.get("pid") != pid:
                raise IrpdUnavailable(
                    f"irpd came back as another process (pid {status.get('pid')}, not {pid}) "
                    f"during its restart onto set {set_id}; its set is {status.get('set_id')}"
                )
            if last.get("requested_ns") == requested and requested is not None:
                break
            if time.monotonic() > deadline:
                raise IrpdUnavailable(f"irpd did not come back from its restart onto set {set_id} within {limit:.1f} s")
            time.sleep(0.05)
        if last.get("fell_back"):
            raise RestartFellBack(
                "restart_failed",
                f"irpd could not start set {set_id} (error {last.get('error')}) "
                f"and came back on set {status.get('set_id')}",
                last.get("error_at"),
            )
        return {
            "mode": "restart",
            "set": status.get("set"),
            "set_id": status.get("set_id"),
            "generation": status.get("generation"),
            "pid": pid,
            "downtime_ns": last.get("downtime_ns"),
            "missed_periods": None,
            "basic_period_ns": status.get("basic_period_ns"),
            "macro_period_ns": status.get("macro_period_ns"),
            "expected_downtime_ns": asked.get("expected_downtime_ns"),
        }


class Restorer(threading.Thread):
    """The watcher: polls irpd's status every `poll_s` on a connection of its own; when irpd is
    new (restarted) and runs another set than the store's active one, loads the active one."""

    RETRY_FIRST_S = 2.0
    RETRY_MAX_S = 60.0

    def __init__(
        self, activator: Activator, socket_path: str, events: AgentEvents, audit: AuditLog, poll_s: float = 1.0
    ):
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
        if self.activator.busy():  # an activation (maybe a managed restart) is under way: not now
            return
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
        self.events.add(
            "irpd_connected",
            f"irpd (pid {pid}) answers{' again' if came_back else ''}; running set {status.get('set_id')}",
        )
        self.restore(status)

    def restore(self, status: dict) -> None:
        active = self.activator.store.active_id()
        if active is None or status.get("set_id") == active:
            self.retry_at, self.retry_s = None, self.RETRY_FIRST_S
            return
        try:
            done = self.activator.restore()
        except (StoreError, IrpdRefused, IrpdUnavailable) as e:
            self.events.add(
                "restore_failed",
                f"could not restore set {active}: {e}; trying again in {self.retry_s:g} s",
                set_id=active,
            )
            self.audit.write("restore", who=AGENT, client=None, target=active, result="error", detail=str(e))
            self.retry_at = time.monotonic() + self.retry_s
            self.retry_s = min(2 * self.retry_s, self.RETRY_MAX_S)
            return
        self.retry_at, self.retry_s = None, self.RETRY_FIRST_S
        if done is None:  # irpd runs the active set after all (an activation just put it there)
            return
        replaced, active, report = done
        self.audit.write(
            "restore",
            who=AGENT,
            client=None,
            target=active,
            result="ok",
            generation=(report or {}).get("generation"),
            replaced=replaced,
        )


def irpd_validation(irpd: IrpdClient, module_xml, timeout_s: float = 30.0) -> dict:
    """irpd's `check` of a stored set, as the manifest's validation report, each error also as a
    problem saying where it points in the set.  irpd unreachable (or too old to check): stored
    unchecked, valid null, and a warning that says so."""
    unchecked = {
        "valid": None,
        "errors": [],
        "problems": [],
        "schedule": None,
        "online": None,
        "restart": None,
        "variables": None,
        "modules": None,
    }
    try:
        result = irpd.request("check", config=str(module_xml), timeout=timeout_s) or {}
    except IrpdUnavailable:
        return {**unchecked, "warnings": ["not checked: irpd unreachable"]}
    except IrpdRefused as e:
        return {**unchecked, "warnings": [f"not checked: irpd cannot check sets ({e})"]}
    errors = [str(x) for x in result.get("errors") or []]
    return {
        "valid": bool(result.get("valid")),
        "errors": errors,
        "problems": problems(result.get("problems") or [], Path(module_xml).parent),
        "warnings": [str(x) for x in result.get("warnings") or []],
        "schedule": result.get("schedule"),
        "online": result.get("online"),
        "restart": result.get("restart"),
        "variables": result.get("variables"),
        "modules": result.get("modules"),
    }
