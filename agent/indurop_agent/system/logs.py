"""logs.py -- irpd's and the agent's logs for the System page: read (the last lines, a search string,
a since time) and followed live.  Two sources, chosen per log:

- a file (`--irpd-log`, `--agent-log`), as packaging/demo.sh writes them: one line per output line,
  "2026-01-31T08:00:00Z <the line>" (a line without that stamp takes the time of the one before);
- the journal, when journald runs and no file is given: `journalctl --output=json -u irpd.service`
  (or indurop-agent.service), with --since, --grep and -f.  The agent's user reads it through the
  group systemd-journal (the package adds it).

Every read is bounded: lines (max_lines), the bytes scanned from a file's end, the length of one
message, and journalctl's run time.  The search is a plain string, case-insensitive (never a
regular expression a client could make slow); the journal gets it escaped as --grep and it is
checked again here.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import shutil
import subprocess
from collections import deque
from collections.abc import AsyncIterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

LOGS = ("irpd", "agent")
JOURNAL_UNITS = {"irpd": "irpd.service", "agent": "indurop-agent.service"}
JOURNALD = Path("/run/systemd/journal")  # there when journald runs
MAX_LINES = 5000  # one read answers at most this many lines
MAX_GREP_CHARS = 200
MAX_MESSAGE_CHARS = 8192  # a longer line is cut (and says so)
MAX_SCAN_BYTES = 16 << 20  # a file is read from its end at most this far back
JOURNAL_TIMEOUT_S = 15.0
FOLLOW_POLL_S = 0.5
STAMP = re.compile(r"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?Z) ")


class LogUnavailable(Exception):
    """The log cannot be read: no source for it, or the source failed (the message says which)."""


@dataclass
class LogQuery:
    lines: int = 200
    grep: str | None = None
    since: datetime | None = None  # aware (UTC)

    def matches(self, line: dict) -> bool:
        if self.grep and self.grep.casefold() not in line["message"].casefold():
            return False
        if self.since is not None and line["time"] is not None and _parse_time(line["time"]) < self.since:
            return False
        return True


def _parse_time(text: str) -> datetime:
    return datetime.fromisoformat(text.replace("Z", "+00:00"))


def _iso(t: datetime) -> str:
    return t.astimezone(UTC).isoformat(timespec="microseconds").replace("+00:00", "Z")


def _cut(message: str) -> str:
    if len(message) <= MAX_MESSAGE_CHARS:
        return message
    return message[:MAX_MESSAGE_CHARS] + f" … ({len(message) - MAX_MESSAGE_CHARS} more characters)"


def line_of(log: str, message: str, time: str | None, pid: int | None = None, priority: int | None = None) -> dict:
    """One log line as the API answers it (models.LogLine)."""
    return {"log": log, "time": time, "message": _cut(message), "pid": pid, "priority": priority}


# ---- files -----------------------------------------------------------------------------------
class FileLog:
    """A log file: read from its end, followed by polling its size (a file that was truncated or
    replaced, as a rotation does, is read again from its start)."""

    def __init__(self, log: str, path: Path):
        self.log, self.path = log, path

    def describe(self) -> str:
        return f"file {self.path}"

    def _lines(self, data: bytes, time: str | None) -> tuple[list[dict], str | None]:
        out = []
        for raw in data.decode("utf-8", "replace").splitlines():
            stamped = STAMP.match(raw)
            if stamped:
                time, raw = stamped.group(1), raw[stamped.end() :]
            out.append(line_of(self.log, raw, time))
        return out, time

    def read(self, query: LogQuery) -> tuple[list[dict], bool]:
        """The last `query.lines` lines that match: (lines, truncated: older lines were not scanned)."""
        lines, truncated, _, _ = self._tail(query, partial=True)
        return lines, truncated

    def _tail(self, query: LogQuery, partial: bool) -> tuple[list[dict], bool, int | None, int]:
        """read()'s answer (with a last line still being written, if `partial`), the file's inode and
        the offset after its last whole line (where a follow goes on)."""
        try:
            with open(self.path, "rb") as f:
                inode = os.fstat(f.fileno()).st_ino
                size = f.seek(0, os.SEEK_END)
                start = max(0, size - MAX_SCAN_BYTES)
                f.seek(start)
                data = f.read(size - start)
        except FileNotFoundError:
            return [], False, None, 0  # nothing written yet
        except OSError as e:
            raise LogUnavailable(f"cannot read the {self.log} log {self.path}: {e.strerror}") from e
        truncated = start > 0
        if truncated:  # the first line was cut by the start of the window
            data = data[data.find(b"\n") + 1 :]
        cut = data.rfind(b"\n") + 1  # a follow reads a last line still being written when it is whole
        lines, _ = self._lines(data if partial else data[:cut], None)
        kept = deque((x for x in lines if query.matches(x)), maxlen=query.lines)
        return list(kept), truncated, inode, size - (len(data) - cut)

    async def follow(self, query: LogQuery) -> AsyncIterator[dict]:
        """The last `query.lines` matching lines, then every new matching line as it is written."""
        # where the first read ended, taken with it: what is written later is the follow's
        lines, _, inode, position = await asyncio.to_thread(self._tail, query, False)
        for line in lines:
            yield line
        time, pending = None, b""
        while True:
            await asyncio.sleep(FOLLOW_POLL_S)
            try:
                st = await asyncio.to_thread(os.stat, self.path)
            except FileNotFoundError:
                continue
            if st.st_ino != inode or st.st_size < position:  # replaced or truncated: from its start
                inode, position, pending = st.st_ino, 0, b""
            if st.st_size == position:
                continue
            data = await asyncio.to_thread(self._read_from, position, min(st.st_size - position, MAX_SCAN_BYTES))
            position += len(data)
            data = pending + data
            cut = data.rfind(b"\n") + 1
            data, pending = data[:cut], data[cut:]
            if len(pending) > MAX_SCAN_BYTES:  # a line that never ends
                data, pending = pending, b""
            lines, time = self._lines(data, time)
            for line in lines:
                if query.matches(line):
                    yield line

    def _read_from(self, position: int, count: int) -> bytes:
        with open(self.path, "rb") as f:
            f.seek(position)
            return f.read(count)


# ---- the journal -----------------------------------------------------------------------------
def _journal_line(log: str, raw: bytes) -> dict | None:
    """One entry of `journalctl --output=json` as a log line (None: not an entry)."""
    try:
        entry = json.loads(raw)
    except ValueError:
        return None
    if not isinstance(entry, dict):
        return None
    message = entry.get("MESSAGE")
    if isinstance(message, list):  # journald gives a message that is not valid UTF-8 as its bytes
        message = bytes(b for b in message if isinstance(b, int) and 0 <= b < 256).decode("utf-8", "replace")
    elif not isinstance(message, str):
        message = "" if message is None else str(message)
    time = None
    try:
        time = _iso(datetime.fromtimestamp(int(entry["__REALTIME_TIMESTAMP"]) / 1e6, UTC))
    except (KeyError, TypeError, ValueError, OverflowError, OSError):
        pass

    def number(key: str) -> int | None:
        try:
            return int(entry[key])
        except (KeyError, TypeError, ValueError):
            return None

    return line_of(log, message, time, number("_PID"), number("PRIORITY"))


class JournalLog:
    """A unit's entries in the journal, through journalctl."""

    def __init__(self, log: str, unit: str, journalctl: str):
        self.log, self.unit, self.journalctl = log, unit, journalctl

    def describe(self) -> str:
        return f"journal, unit {self.unit}"

    def _command(self, query: LogQuery, follow: bool) -> list[str]:
        cmd = [
            self.journalctl,
            "--output=json",
            "--no-pager",
            "--quiet",
            f"--unit={self.unit}",
            f"--lines={query.lines}",
        ]
        if query.since is not None:
            cmd.append(f"--since=@{query.since.timestamp():.6f}")
        if query.grep:
            cmd += [f"--grep={re.escape(query.grep)}", "--case-sensitive=false"]
        if follow:
            cmd.append("--follow")
        return cmd

    def read(self, query: LogQuery) -> tuple[list[dict], bool]:
        try:
            done = subprocess.run(
                self._command(query, False),
                capture_output=True,
                timeout=JOURNAL_TIMEOUT_S,
                stdin=subprocess.DEVNULL,
                check=False,
            )
        except subprocess.TimeoutExpired as e:
            raise LogUnavailable(f"journalctl did not answer within {JOURNAL_TIMEOUT_S:g} s") from e
        except OSError as e:
            raise LogUnavailable(f"journalctl cannot run: {e.strerror}") from e
        said = done.stderr.decode("utf-8", "replace").strip()
        if "insufficient permissions" in said and not done.stdout.strip():
            raise LogUnavailable(
                "journalctl may not read the journal: the agent's user must be in the group systemd-journal "
                "(the package adds it; restart the agent after adding it by hand)"
            )
        # a failure says why on stderr (no entry matching --grep is no failure: nothing is said)
        if done.returncode != 0 and said:
            raise LogUnavailable(f"journalctl failed: {said[:500]}")
        lines = [x for x in (_journal_line(self.log, raw) for raw in done.stdout.splitlines()) if x]
        return [x for x in lines if query.matches(x)][-query.lines :], False

    async def follow(self, query: LogQuery) -> AsyncIterator[dict]:
        try:
            process = await asyncio.create_subprocess_exec(
                *self._command(query, True),
                stdin=asyncio.subprocess.DEVNULL,
                stdout=asyncio.subprocess.PIPE,
                stderr=asyncio.subprocess.DEVNULL,
                limit=MAX_SCAN_BYTES,
            )
        except OSError as e:
            raise LogUnavailable(f"journalctl cannot run: {e.strerror}") from e
        try:
            while raw := await process.stdout.readline():
                line = _journal_line(self.log, raw)
                if line is not None and query.matches(line):
                    yield line
        finally:  # the client went away (or journalctl ended): never leave it running
            if process.returncode is None:
                process.kill()
                await process.wait()


def sources(settings) -> dict[str, FileLog | JournalLog | None]:
    """Where each log is read from: its file when the settings name one, else the journal when
    journald runs and journalctl is installed, else None."""
    journalctl = shutil.which("journalctl")
    journal = journalctl is not None and JOURNALD.is_dir()
    out: dict[str, FileLog | JournalLog | None] = {}
    for log in LOGS:
        path = getattr(settings, f"{log}_log")
        if path is not None:
            out[log] = FileLog(log, Path(path))
        elif journal:
            out[log] = JournalLog(log, JOURNAL_UNITS[log], journalctl)
        else:
            out[log] = None
    return out


def no_source(log: str) -> str:
    option = "--irpd-log" if log == "irpd" else "--agent-log"
    return (
        f"no {log} log to read: the agent was started without {option} FILE and journald does not run here "
        "(packaging/demo.sh writes both logs to files and names them)"
    )
