"""test_restorer.py -- the agent's restore watcher on its own (fakes for irpd, the store and the
activator): a restarted irpd gets the store's active set back, and a restore that failed (irpd
still busy, a swap that timed out) is tried again with a growing delay instead of waiting for
irpd's next restart; while an activation runs (a managed restart of irpd) the watcher stays out."""

from __future__ import annotations

from indurop_agent.irpd.client import IrpdUnavailable
from indurop_agent.sets.activation import Restorer


class Irpd:
    def __init__(self):
        self.status = {"pid": 10, "set_id": "A"}

    def request(self, cmd, **_):
        assert cmd == "status"
        return dict(self.status)


class Activator:
    def __init__(self, irpd: Irpd, failures: int):
        self.irpd, self.failures, self.calls = irpd, failures, 0
        self.store = self
        self.activating = False

    def active_id(self):
        return "B"

    def busy(self):
        return self.activating

    def restore(self):
        self.calls += 1
        if self.calls <= self.failures:
            raise IrpdUnavailable("irpd did not answer 'load' within 30 s")
        before = self.irpd.status["set_id"]
        self.irpd.status["set_id"] = "B"
        return before, "B", {"generation": 2}


class Log:
    def __init__(self):
        self.lines = []

    def add(self, kind, message, **_):
        self.lines.append((kind, message))

    def write(self, *args, **kw):
        self.lines.append(("audit", kw.get("result")))


def watcher(failures: int, clock):
    irpd = Irpd()
    activator = Activator(irpd, failures)
    log = Log()
    r = Restorer(activator, "/nonexistent.sock", log, log, poll_s=0.01)
    r.client = irpd
    return r, irpd, activator, log


def test_a_failed_restore_is_tried_again_with_a_growing_delay(monkeypatch):
    now = [1000.0]
    monkeypatch.setattr("indurop_agent.sets.activation.time.monotonic", lambda: now[0])
    r, irpd, activator, log = watcher(failures=2, clock=now)
    r.poll_once()  # irpd seen first: restore, fails
    assert activator.calls == 1 and irpd.status["set_id"] == "A"
    assert any(k == "restore_failed" and "again in 2 s" in m for k, m in log.lines)
    now[0] += 1.0
    r.poll_once()  # same irpd, before the retry time: nothing
    assert activator.calls == 1
    now[0] += 1.5
    r.poll_once()  # retried, fails again; next delay 4 s
    assert activator.calls == 2
    assert any(k == "restore_failed" and "again in 4 s" in m for k, m in log.lines)
    now[0] += 3.0
    r.poll_once()
    assert activator.calls == 2
    now[0] += 1.5
    r.poll_once()  # third try works: irpd runs the active set
    assert activator.calls == 3 and irpd.status["set_id"] == "B"
    now[0] += 100.0
    r.poll_once()  # and nothing more is tried
    assert activator.calls == 3


def test_a_restarted_irpd_is_restored_at_once():
    r, irpd, activator, _ = watcher(failures=0, clock=None)
    r.poll_once()
    assert activator.calls == 1 and irpd.status["set_id"] == "B"
    irpd.status = {"pid": 11, "set_id": None}  # restarted by systemd on its --config
    r.poll_once()
    assert activator.calls == 2 and irpd.status["set_id"] == "B"


def test_the_watcher_stays_out_while_an_activation_runs():
    r, irpd, activator, log = watcher(failures=0, clock=None)
    r.poll_once()
    assert activator.calls == 1
    activator.activating = True  # e.g. a managed restart: irpd away, then on set C
    irpd.status = {"pid": 10, "set_id": "C"}
    for _ in range(3):
        r.poll_once()
    assert activator.calls == 1 and irpd.status["set_id"] == "C"
    assert not any(k in ("irpd_lost", "restore_failed") for k, _ in log.lines)
