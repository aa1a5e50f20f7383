"""config.py -- the agent's settings: command line first, then an optional JSON config file.

Every field of Settings is also a key of the config file (same name); the command line has the
ones that change from one start to the next (address, folders, TLS).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from dataclasses import dataclass
from pathlib import Path

MiB = 1 << 20
INSTALLED_WEBUI = Path("/usr/share/indurop/webui")


def default_webui_dir() -> Path:
    """The web UI built in this source tree (webui/dist beside agent/), else the installed one."""
    built = Path(__file__).resolve().parents[2] / "webui" / "dist"
    return built if built.is_dir() else INSTALLED_WEBUI


@dataclass
class Settings:
    host: str = "127.0.0.1"
    port: int = 8080
    data_dir: Path = Path("/var/lib/indurop")
    irpd_socket: str = "/run/indurop/irpd.sock"
    # TLS: both or neither (PEM files, handed to uvicorn).
    tls_cert: Path | None = None
    tls_key: Path | None = None
    # Set uploads (POST /sets): per file, whole upload (and an archive's unpacked content), files.
    max_file_bytes: int = 64 * MiB
    max_upload_bytes: int = 256 * MiB
    max_files: int = 512
    # Sets with Structured Text (sets/st_build.py): the compiler an upload's .st files are built
    # with (None: st/stc of this source tree, else stc on the PATH, else the installed one) and how
    # long one build may take before it is stopped.
    stc: Path | None = None
    st_build_timeout_s: float = 300.0
    # Every other request's body.
    max_body_bytes: int = 1 * MiB
    # Slow and numerous clients (server.py): a request's line and headers must arrive within
    # header_timeout_s of the connection (or of the previous answer); a body may pause at most
    # body_idle_s between bytes and, but for set uploads, must be complete within body_timeout_s
    # (408 otherwise).  At most max_connections client connections (HTTP and WebSocket) are held;
    # one more is answered 503 with Retry-After.  The agent raises its open-file limit to fit.
    header_timeout_s: float = 10.0
    body_idle_s: float = 20.0
    body_timeout_s: float = 60.0
    max_connections: int = 4096
    # Reverse proxies whose X-Forwarded-For/-Proto the agent believes (comma-separated addresses, as
    # uvicorn's --forwarded-allow-ips).  Empty: none; the client address is the socket's, so that no
    # client can pick the address the lockout counts.  Behind a proxy on this machine: "127.0.0.1".
    forwarded_allow_ips: str = ""
    # Brute-force lockout: this many unknown tokens from one client address within the window
    # lock that address out for the window (429 with Retry-After).
    lockout_attempts: int = 10
    lockout_window_s: float = 60.0
    # Sign-in (docs/administration.md): this many wrong passwords for one user name within the
    # window lock that name for the window (the address counts them too, with the unknown tokens,
    # above).  A browser session ends after session_idle_s without a request of its user, and after
    # session_lifetime_s whatever happens.  At most password_hash_slots password checks at once.
    signin_attempts: int = 5
    signin_window_s: float = 300.0
    session_idle_s: float = 1800.0
    session_lifetime_s: float = 43200.0
    password_hash_slots: int = 2
    # argon2id's cost (argon2-cffi's PasswordHasher; these are its defaults, RFC 9106's low-memory
    # profile).  A password hashed with other values is hashed again at its user's next sign-in.
    argon2_time_cost: int = 3
    argon2_memory_kib: int = 65536
    argon2_parallelism: int = 4
    # How often the agent looks at irpd to notice a (re)connection and restore the active set.
    irpd_poll_s: float = 1.0
    # irpd `load`, `set_period`, ... (a swap at a macro-period boundary) may take this long.
    swap_timeout_s: float = 30.0
    # The built web UI (index.html and its assets), served at / (None: default_webui_dir()).
    webui_dir: Path | None = None
    # The 3D view of the running set's robot (docs/robot-view.md): which viewer serves it, how often
    # its joints follow the shared variables, how long a viewer ticket (the iframe's URL) and the
    # cookie it is traded for stay valid.
    viewer: str = "viser"
    robot_rate_hz: float = 30.0
    viewer_ticket_s: float = 600.0
    viewer_session_s: float = 3600.0
    # Alarms (docs/alarms.md).  The system alarms: a module's overruns (deadline misses) in one
    # second, as irpd's events count them, that raise <module>/overruns (<module>/deadline_misses);
    # the seconds without such a second that clear it; the seconds irpd may not answer before
    # agent/irpd_unreachable.  How often the alarm segment is read.  The history's bound (rows in
    # <data-dir>/alarms.sqlite3; the oldest go first) and the rows one module's alarms may add in
    # one second (more transitions change the states but are counted as a flood, not recorded).
    alarm_overruns_per_s: int = 10
    alarm_misses_per_s: int = 10
    alarm_clear_s: float = 10.0
    alarm_unreachable_s: float = 5.0
    alarm_poll_s: float = 0.1
    alarm_history_rows: int = 200_000
    alarm_history_per_s: int = 100
    # The System page (docs/administration.md).  Logs: irpd's and the agent's output as files
    # (packaging/demo.sh writes them; --irpd-log, --agent-log), else the journal when journald runs.
    # A backup's restore: at most this many bytes (the upload, and separately what it unpacks to)
    # and this many archive members.
    irpd_log: Path | None = None
    agent_log: Path | None = None
    max_backup_bytes: int = 4 << 30
    max_backup_members: int = 200_000
    # The line (GET /line, docs/dds.md "The line"): the view of the line the DDS bridge writes
    # (its --line-file).
    line_file: Path = Path("/run/indurop-dds/line.json")
    # The recorder (docs/recorder.md): <data-dir>/recordings/ holds at most recordings_quota_bytes
    # (the oldest recordings and captures are deleted first to stay under it, never one being
    # written); recordings stop cleanly when the data folder's disk has less than
    # recordings_min_free_bytes free.
    recordings_quota_bytes: int = 4 << 30
    recordings_min_free_bytes: int = 256 * MiB


FIELDS = {f.name: f for f in dataclasses.fields(Settings)}
PATHS = {"data_dir", "tls_cert", "tls_key", "webui_dir", "irpd_log", "agent_log", "line_file", "stc"}
OPTIONAL_PATHS = {"tls_cert", "tls_key", "webui_dir", "irpd_log", "agent_log", "stc"}
POSITIVE = {
    "port",
    "max_file_bytes",
    "max_upload_bytes",
    "max_files",
    "st_build_timeout_s",
    "max_body_bytes",
    "header_timeout_s",
    "body_idle_s",
    "body_timeout_s",
    "max_connections",
    "lockout_attempts",
    "lockout_window_s",
    "signin_attempts",
    "signin_window_s",
    "session_idle_s",
    "session_lifetime_s",
    "password_hash_slots",
    "argon2_time_cost",
    "argon2_memory_kib",
    "argon2_parallelism",
    "irpd_poll_s",
    "swap_timeout_s",
    "robot_rate_hz",
    "viewer_ticket_s",
    "viewer_session_s",
    "alarm_overruns_per_s",
    "alarm_misses_per_s",
    "alarm_clear_s",
    "alarm_unreachable_s",
    "alarm_poll_s",
    "alarm_history_rows",
    "alarm_history_per_s",
    "max_backup_bytes",
    "max_backup_members",
    "recordings_quota_bytes",
    "recordings_min_free_bytes",
}
MIN_RECORDINGS_QUOTA = 16 * MiB  # a quota smaller than this could not hold a second of a fast recording
VIEWERS = ("viser", "meshcat")


def _coerce(key: str, value, where: str) -> object:
    """A config-file value of the field's type, or ValueError naming the key and what it needs."""
    if value is None and key in OPTIONAL_PATHS:
        return None
    if key in PATHS:
        if not isinstance(value, str) or not value:
            raise ValueError(f"{where}: '{key}' must be a path (a string)")
        return Path(value)
    default = getattr(Settings, key)
    if isinstance(default, bool) or not isinstance(default, (int, float, str)):
        raise ValueError(f"{where}: '{key}' cannot be set")
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError(f"{where}: '{key}' must be a string")
        return value
    wrong_type = isinstance(value, bool) or not isinstance(value, (int, float))
    if wrong_type or (isinstance(default, int) and not isinstance(value, int)):
        raise ValueError(f"{where}: '{key}' must be {'an integer' if isinstance(default, int) else 'a number'}")
    return value


def check(s: Settings) -> list[str]:
    """What is wrong with a Settings, as messages that say what to fix (empty: nothing)."""
    problems = []
    for key in sorted(POSITIVE):
        if not getattr(s, key) > 0:
            problems.append(f"{key} must be greater than 0 (it is {getattr(s, key)})")
    if not 0 < int(s.port) < 65536:
        problems.append(f"port {s.port} is not a TCP port")
    if s.viewer not in VIEWERS:
        problems.append(f"viewer {s.viewer!r} is not one of {', '.join(VIEWERS)}")
    if s.argon2_memory_kib < 8 * s.argon2_parallelism:
        problems.append(
            f"argon2_memory_kib ({s.argon2_memory_kib}) must be at least 8 × argon2_parallelism ({s.argon2_parallelism})"
        )
    if s.session_idle_s > s.session_lifetime_s:
        problems.append(
            f"session_idle_s ({s.session_idle_s}) is longer than session_lifetime_s ({s.session_lifetime_s})"
        )
    if s.recordings_quota_bytes < MIN_RECORDINGS_QUOTA:
        problems.append(
            f"recordings_quota_bytes ({s.recordings_quota_bytes}) is too small: give at least {MIN_RECORDINGS_QUOTA} "
            "(16 MiB), or the recordings cannot be kept"
        )
    if s.max_file_bytes > s.max_upload_bytes:
        problems.append(f"max_file_bytes ({s.max_file_bytes}) is larger than max_upload_bytes ({s.max_upload_bytes})")
    if (s.tls_cert is None) != (s.tls_key is None):
        given, missing = ("--tls-cert", "--tls-key") if s.tls_cert is not None else ("--tls-key", "--tls-cert")
        problems.append(f"{given} needs {missing} too (TLS takes both the certificate and its key, or neither)")
    for key in ("tls_cert", "tls_key"):
        path = getattr(s, key)
        if path is not None and not os.access(path, os.R_OK):
            problems.append(f"{key} {path} cannot be read")
    return problems


def parse(argv: list[str] | None = None) -> Settings:
    ap = argparse.ArgumentParser(prog="indurop-agent", description="indurop's REST/WebSocket agent (non-RT)")
    ap.add_argument("--config", type=Path, help=f"a JSON file with any of: {', '.join(FIELDS)}")
    ap.add_argument("--host", help="address to listen on (default 127.0.0.1)")
    ap.add_argument("--port", type=int)
    ap.add_argument("--data-dir", type=Path, help="users, tokens, sessions, the set store, the audit log")
    ap.add_argument("--irpd-socket", help="irpd's control socket")
    ap.add_argument("--tls-cert", type=Path, help="serve HTTPS with this PEM certificate (needs --tls-key)")
    ap.add_argument("--tls-key", type=Path, help="the PEM private key of --tls-cert")
    ap.add_argument(
        "--webui-dir",
        type=Path,
        help=f"the built web UI to serve at / (default: webui/dist of this source tree when built, "
        f"else {INSTALLED_WEBUI})",
    )
    ap.add_argument("--viewer", choices=VIEWERS, help="the 3D robot view's viewer (default viser)")
    ap.add_argument(
        "--irpd-log",
        type=Path,
        help="a file irpd's output is written to (the System page's logs; default: the journal)",
    )
    ap.add_argument("--agent-log", type=Path, help="a file this agent's output is written to (as --irpd-log)")
    ap.add_argument(
        "--line-file",
        type=Path,
        help="the view of the line the DDS bridge writes (its --line-file; default /run/indurop-dds/line.json)",
    )
    a = ap.parse_args(argv)
    s = Settings()
    if a.config:
        where = f"--config {a.config}"
        try:
            values = json.loads(a.config.read_text())
        except (OSError, ValueError) as e:
            ap.error(f"{where}: {e}")
        if not isinstance(values, dict):
            ap.error(f"{where}: expected a JSON object with any of: {', '.join(FIELDS)}")
        unknown = set(values) - set(FIELDS)
        if unknown:
            ap.error(f"{where}: unknown keys {', '.join(sorted(unknown))}; the keys are {', '.join(FIELDS)}")
        for key, value in values.items():
            try:
                setattr(s, key, _coerce(key, value, where))
            except ValueError as e:
                ap.error(str(e))
    for key in (
        "host",
        "port",
        "data_dir",
        "irpd_socket",
        "tls_cert",
        "tls_key",
        "webui_dir",
        "viewer",
        "irpd_log",
        "agent_log",
        "line_file",
    ):
        if getattr(a, key) is not None:
            setattr(s, key, getattr(a, key))
    problems = check(s)
    if problems:
        ap.error("; ".join(problems))
    return s
