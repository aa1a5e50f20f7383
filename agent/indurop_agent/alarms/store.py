"""store.py -- where the alarms persist: <data-dir>/alarms.sqlite3 (SQLite from the standard library).

Three tables:
- `history`: one row per transition (raised, cleared, acknowledged, shelved, unshelved, ...), its
  `seq` increasing for good (AUTOINCREMENT: a seq is never used twice, so it is a cursor for
  `irpctl alarms --follow`).  Bounded: beyond `max_rows` the oldest rows are deleted.
- `alarms`: every alarm that is not normal, or shelved, as the JSON of its state (manager.py).
- `meta`: the cursors that let a restarted agent go on where it stopped (irpd's event log, the
  alarm ring) and the flood counters.

Why SQLite: one file written in transactions (a crash leaves the last committed state, never a
torn line), indexed filters and paging for the history, and WAL lets the API's readers query
while the watcher writes.  Every write is one transaction, synced (synchronous=FULL) before it
returns, as the audit log is: an acknowledgement the API confirmed is on disk.  A database that
does not open (corrupt, from a newer agent) is moved aside as alarms.sqlite3.unreadable-<time>
and a new one started; the caller says so in the agent's events.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

SCHEMA_VERSION = 1
SCHEMA = """
CREATE TABLE IF NOT EXISTS history (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    time_ns INTEGER NOT NULL,
    key TEXT NOT NULL,
    module TEXT NOT NULL,
    alarm_id TEXT NOT NULL,
    event TEXT NOT NULL,
    state TEXT NOT NULL,
    severity TEXT NOT NULL,
    text TEXT NOT NULL,
    detail TEXT NOT NULL DEFAULT '',
    value REAL NOT NULL DEFAULT 0,
    who TEXT,
    note TEXT NOT NULL DEFAULT '',
    flags TEXT NOT NULL DEFAULT '',
    count INTEGER NOT NULL DEFAULT 1
);
CREATE INDEX IF NOT EXISTS history_time ON history(time_ns);
CREATE INDEX IF NOT EXISTS history_module ON history(module, time_ns);
CREATE TABLE IF NOT EXISTS alarms (key TEXT PRIMARY KEY, body TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT NOT NULL);
"""
COLUMNS = (
    "seq",
    "time_ns",
    "key",
    "module",
    "alarm_id",
    "event",
    "state",
    "severity",
    "text",
    "detail",
    "value",
    "who",
    "note",
    "flags",
    "count",
)


@dataclass(frozen=True)
class HistoryFilter:
    """What GET /alarms/history asks for: every field optional."""

    since_ns: int | None = None
    until_ns: int | None = None
    module: str | None = None
    key: str | None = None
    severity: str | None = None
    state: str | None = None
    after_seq: int | None = None  # rows with a larger seq only (irpctl alarms --follow)

    def where(self) -> tuple[str, list]:
        parts, args = [], []
        for column, op, value in (
            ("time_ns", ">=", self.since_ns),
            ("time_ns", "<=", self.until_ns),
            ("module", "=", self.module),
            ("key", "=", self.key),
            ("severity", "=", self.severity),
            ("state", "=", self.state),
            ("seq", ">", self.after_seq),
        ):
            if value is not None:
                parts.append(f"{column} {op} ?")
                args.append(value)
        return (" WHERE " + " AND ".join(parts)) if parts else "", args


def _row(values: tuple) -> dict:
    row = dict(zip(COLUMNS, values))
    row["who"] = json.loads(row["who"]) if row["who"] else None
    row["flags"] = row["flags"].split(",") if row["flags"] else []
    return row


class AlarmStore:
    def __init__(self, path: Path, max_rows: int):
        self.path = path
        self.max_rows = max_rows
        self.moved_aside: Path | None = None  # a database that did not open, renamed
        self._lock = threading.Lock()
        try:
            self._db = self._open()
        except sqlite3.DatabaseError:
            self.moved_aside = path.with_name(f"{path.name}.unreadable-{time.strftime('%Y%m%dT%H%M%S')}")
            path.rename(self.moved_aside)
            for suffix in ("-wal", "-shm"):
                path.with_name(path.name + suffix).unlink(missing_ok=True)
            self._db = self._open()

    def _open(self) -> sqlite3.Connection:
        db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        try:
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=FULL")
            version = db.execute("PRAGMA user_version").fetchone()[0]
            if version not in (0, SCHEMA_VERSION):
                raise sqlite3.DatabaseError(f"schema version {version}, this agent writes {SCHEMA_VERSION}")
            db.executescript(SCHEMA)
            db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        except sqlite3.DatabaseError:
            db.close()
            raise
        return db

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # ---- state ------------------------------------------------------------------------------------
    def load(self) -> tuple[list[dict], dict]:
        """(every stored alarm's state, the meta values)."""
        with self._lock:
            alarms = [json.loads(body) for (body,) in self._db.execute("SELECT body FROM alarms")]
            meta = {name: json.loads(value) for name, value in self._db.execute("SELECT name, value FROM meta")}
        return alarms, meta

    def write(self, rows: list[dict], alarms: dict[str, dict | None], meta: dict | None = None) -> list[dict]:
        """One transaction: history rows appended (their seq set), alarm states replaced (None:
        deleted), meta values set; the oldest history rows beyond max_rows deleted."""
        if not rows and not alarms and not meta:
            return rows
        with self._lock:
            db = self._db
            db.execute("BEGIN IMMEDIATE")
            try:
                for r in rows:
                    cur = db.execute(
                        "INSERT INTO history (time_ns, key, module, alarm_id, event, state, severity, text, detail,"
                        " value, who, note, flags, count) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                        (
                            r["time_ns"],
                            r["key"],
                            r["module"],
                            r["alarm_id"],
                            r["event"],
                            r["state"],
                            r["severity"],
                            r["text"],
                            r.get("detail") or "",
                            float(r.get("value") or 0.0),
                            json.dumps(r["who"]) if r.get("who") else None,
                            r.get("note") or "",
                            ",".join(r.get("flags") or ()),
                            int(r.get("count", 1)),
                        ),
                    )
                    r["seq"] = cur.lastrowid
                for key, body in alarms.items():
                    if body is None:
                        db.execute("DELETE FROM alarms WHERE key = ?", (key,))
                    else:
                        db.execute("INSERT OR REPLACE INTO alarms (key, body) VALUES (?, ?)", (key, json.dumps(body)))
                for name, value in (meta or {}).items():
                    db.execute("INSERT OR REPLACE INTO meta (name, value) VALUES (?, ?)", (name, json.dumps(value)))
                if rows:
                    db.execute("DELETE FROM history WHERE seq <= ?", (rows[-1]["seq"] - self.max_rows,))
                db.execute("COMMIT")
            except BaseException:
                db.execute("ROLLBACK")
                raise
        return rows

    # ---- history ----------------------------------------------------------------------------------
    def _reader(self) -> sqlite3.Connection:
        """A connection of the caller's own (WAL: it reads while the watcher writes)."""
        return sqlite3.connect(f"file:{self.path}?mode=ro", uri=True)

    def query(self, f: HistoryFilter, limit: int, offset: int = 0) -> tuple[list[dict], int]:
        """(rows matching f, newest first, at most limit after offset; how many match)."""
        where, args = f.where()
        db = self._reader()
        try:
            total = db.execute(f"SELECT COUNT(*) FROM history{where}", args).fetchone()[0]
            rows = db.execute(
                f"SELECT {', '.join(COLUMNS)} FROM history{where} ORDER BY seq DESC LIMIT ? OFFSET ?",
                [*args, limit, offset],
            ).fetchall()
        finally:
            db.close()
        return [_row(r) for r in rows], total

    def rows(self, f: HistoryFilter, batch: int = 1000) -> Iterator[dict]:
        """Every row matching f, oldest first, read in batches (the CSV export)."""
        last = f.after_seq or 0
        db = self._reader()
        try:
            while True:
                where, args = replace(f, after_seq=last).where()
                page = db.execute(
                    f"SELECT {', '.join(COLUMNS)} FROM history{where} ORDER BY seq ASC LIMIT ?", [*args, batch]
                ).fetchall()
                yield from (_row(r) for r in page)
                if len(page) < batch:
                    return
                last = page[-1][0]
        finally:
            db.close()

    def last_seq(self) -> int:
        db = self._reader()
        try:
            return db.execute("SELECT COALESCE(MAX(seq), 0) FROM history").fetchone()[0]
        finally:
            db.close()
