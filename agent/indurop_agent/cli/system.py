"""system.py -- irpctl's administration commands (docs/irpctl.md, docs/administration.md):
system, backup, restore, restart irpd|agent, logs irpd|agent, tls, and `sets prune`.  irpctl.py adds
SYSTEM_COMMANDS to its command table; each entry is (name, help, run, arguments) as its Command."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from .base import EXIT_OK, arg, parse_time
from .text import _size, _uptime, pairs, sets_text, table


def _since(text: str) -> str:
    try:
        return parse_time(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _whole(minimum: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"'{text}': give {minimum} or more")
        return value

    return parse


_count, _positive = _whole(0), _whole(1)


# -- what it prints --------------------------------------------------------------------------------
def system_text(s: dict) -> str:
    agent, irpd, data, cert = s["agent"], s["irpd"], s["data"], s.get("tls")
    items: list[tuple[str, Any]] = [
        ("agent", f"{agent['version']}, pid {agent['pid']}, up {_uptime(agent['uptime_s'] * 1e9)}"),
        ("serving", f"{agent['scheme']}://{agent['host']}:{agent['port']}/"),
        ("restarted by", agent.get("supervisor") or "nothing (a restart of the agent is refused)"),
    ]
    if irpd["reachable"]:
        items.append(
            (
                "irpd",
                f"{irpd.get('version') or '?'}, pid {irpd['pid']}, up {_uptime((irpd['uptime_s'] or 0) * 1e9)}, set {irpd.get('set_id') or '-'}",
            )
        )
    else:
        items.append(("irpd", f"unreachable ({irpd.get('detail')})"))
    items += [
        (
            "data folder",
            f"{data['path']}: {_size(data['used_bytes'])} used, {_size(data['free_bytes'])} free of {_size(data['filesystem_bytes'])}",
        ),
        ("logs", f"irpd: {s['logs']['irpd'] or '-'}; agent: {s['logs']['agent'] or '-'}"),
    ]
    if cert is None:
        items.append(("TLS", "none (plain HTTP)"))
    elif cert.get("error"):
        items.append(("TLS", cert["error"]))
    else:
        items += [
            ("TLS certificate", f"{cert['subject']}{' (self-signed)' if cert.get('self_signed') else ''}"),
            ("SHA-256", cert["fingerprint_sha256"]),
            ("valid until", f"{cert['not_after']} ({cert['days_left']} days)"),
        ]
    if s.get("restore_pending"):
        items.append(("restore", "staged: applied when the agent starts again"))
    return pairs(items)


def restore_text(p: dict) -> str:
    a = p["archive"]
    sets = p["sets"]

    def change(key: str) -> str:
        now, after = p[key]["now"], p[key]["after"]
        return f"{now if now is not None else '-'} -> {after if after is not None else '-'}"

    lines = [
        pairs(
            [
                (
                    "backup",
                    f"of {a['host']}, {a['created']}, agent {a['agent_version']}, {a['files']} files, "
                    f"{_size(a['bytes'])}{', with secrets' if a['with_secrets'] else ''}",
                ),
                (
                    "sets",
                    f"{len(sets['added'])} added, {len(sets['present'])} already here, {len(sets['kept'])} only here (kept)",
                ),
                ("active set", change("active_set")),
                ("tokens", change("tokens")),
                ("users", change("users")),
                ("audit lines", change("audit_lines")),
            ]
        ),
        "",
        table(["FILE", "ACTION", "WHAT"], [[f["path"], f["action"], f["what"]] for f in p["files"]])
        if p["files"]
        else "(no files)",
    ]
    lines += [f"warning: {w}" for w in p["warnings"]]
    if p["dry_run"]:
        lines.append("(dry run: nothing changed; run it again without --dry-run to restore)")
    elif p.get("restarting"):
        lines.append("(staged: the agent restarts now to apply it)")
    else:
        lines.append("(staged: applied when the agent starts again)")
    return "\n".join(lines)


def prune_text(r: dict) -> str:
    verb = "would delete" if r["dry_run"] else "deleted"
    rows = [[s["id"], s["created"], s["files"], (s.get("by") or {}).get("name", "-")] for s in r["deleted"]]
    head = f"{verb} {len(r['deleted'])} set(s) and {len(r['blobs'])} stored file(s), {_size(r['bytes'])}; kept {len(r['kept'])}"
    return head + ("\n\n" + table(["SET", "CREATED", "FILES", "BY"], rows, "llrl") if rows else "")


def restart_text(r: dict) -> str:
    if "downtime_ns" in r:
        return f"irpd restarted onto set {r.get('set_id') or '-'} (pid {r.get('pid')}, downtime {(r.get('downtime_ns') or 0) / 1e6:.1f} ms)"
    return r.get("detail") or "the agent restarts"


def log_line(line: dict) -> str:
    return f"{line.get('time') or '-':<27} {line['message']}"


# -- the commands ----------------------------------------------------------------------------------
def cmd_system(c, a, out) -> int:
    out.show(c.system(), system_text)
    return EXIT_OK


def cmd_backup(c, a, out) -> int:
    path = c.backup(a.output, with_secrets=a.with_secrets)
    if out.as_json:
        out.json({"file": str(path), "bytes": path.stat().st_size})
    else:
        out.line(
            f"wrote {path} ({_size(path.stat().st_size)}){' with secrets: keep it safe' if a.with_secrets else ''}"
        )
    return EXIT_OK


def cmd_restore(c, a, out) -> int:
    out.show(c.restore(a.archive, dry_run=a.dry_run), restore_text)
    return EXIT_OK


def cmd_restart(c, a, out) -> int:
    out.show(c.restart(a.what), restart_text)
    return EXIT_OK


def cmd_logs(c, a, out) -> int:
    if a.follow:
        for line in c.follow_logs(a.log, lines=a.lines, grep=a.grep, since=a.since):
            out.json(line) if out.as_json else out.line(log_line(line))
        return EXIT_OK
    page = c.logs(a.log, lines=a.lines, grep=a.grep, since=a.since)
    if out.as_json:
        out.json(page)
    else:
        for line in page["lines"]:
            out.line(log_line(line))
        if page.get("truncated"):
            print("irpctl: (older lines of the file were not searched)", file=sys.stderr)
    return EXIT_OK


def cmd_tls(c, a, out) -> int:
    done = c.upload_tls(a.cert, a.key)
    cert = done["certificate"]
    out.show(
        done,
        lambda d: (
            f"installed {cert['subject']}, SHA-256 {cert['fingerprint_sha256']}, valid until {cert['not_after']}"
            + ("; the agent restarts to serve it" if d["restarting"] else "; restart the agent to serve it")
        ),
    )
    return EXIT_OK


def cmd_sets(c, a, out) -> int:
    """`irpctl sets` lists the sets; `irpctl sets prune --keep N [--dry-run]` prunes them."""
    if a.action is None:
        if a.keep is not None or a.dry_run:
            print("irpctl sets: --keep and --dry-run go with `sets prune`", file=sys.stderr)
            return 2
        out.show(c.sets(), sets_text)
        return EXIT_OK
    if a.keep is None:
        print("irpctl sets prune: give --keep N (the newest N sets are kept, and the active one)", file=sys.stderr)
        return 2
    out.show(c.prune_sets(a.keep, dry_run=a.dry_run), prune_text)
    return EXIT_OK


SETS_ARGS = (
    arg("action", nargs="?", choices=("prune",), help="prune: delete old sets and the files only they use (admin)"),
    arg("--keep", type=_count, metavar="N", help="with prune: keep the newest N sets (and the active one)"),
    arg("--dry-run", action="store_true", help="with prune: only say what would be deleted"),
)
LOG = arg("log", choices=("irpd", "agent"), help="whose log")
SYSTEM_COMMANDS = (
    ("system", "versions, uptimes, disk use, the TLS certificate (admin)", cmd_system, ()),
    (
        "backup",
        "download a backup of the data folder (admin)",
        cmd_backup,
        (
            arg("-o", "--output", metavar="FILE", help="where to write it (default: the name the agent gives, here)"),
            arg("--with-secrets", action="store_true", help="also the users' password hashes and the TLS key"),
        ),
    ),
    (
        "restore",
        "restore a backup (admin): checked whole first; --dry-run says what it would replace",
        cmd_restore,
        (
            arg("archive", metavar="FILE", help="a backup (.tar.gz) from `irpctl backup`"),
            arg("--dry-run", action="store_true", help="check it and show what it would replace; change nothing"),
        ),
    ),
    (
        "restart",
        "restart irpd (onto the active set, safe outputs first) or the agent (admin)",
        cmd_restart,
        (arg("what", choices=("irpd", "agent")),),
    ),
    (
        "logs",
        "irpd's or the agent's log (admin)",
        cmd_logs,
        (
            LOG,
            arg("--follow", "-f", action="store_true", help="keep printing new lines (Ctrl-C stops)"),
            arg("--grep", metavar="TEXT", help="only lines holding TEXT (any case)"),
            arg("--since", type=_since, metavar="TIME", help="from TIME (ISO 8601, or 30m, 2h, 1d ago)"),
            arg("--lines", "-n", type=_positive, default=200, metavar="N", help="the last N lines (default 200)"),
        ),
    ),
    (
        "tls",
        "replace the agent's TLS certificate and key (admin)",
        cmd_tls,
        (arg("cert", metavar="CERT.pem"), arg("key", metavar="KEY.pem")),
    ),
)
