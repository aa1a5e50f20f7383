"""test_system_cli.py -- irpctl's administration commands against a real agent (no irpd needed):
system, backup -o, restore --dry-run, sets prune --keep N [--dry-run], logs with --grep and
--since, and their usage errors.  docs/irpctl.md."""

from __future__ import annotations

import json
import tarfile

import pytest
from agent_helpers import free_port, start_agent, stop
from indurop_agent.cli import irpctl as cli
from indurop_agent.system import logs


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("system-cli")
    log = tmp / "agent.log"
    log.write_text("2026-01-31T08:00:00Z agent: started\n2026-01-31T09:00:00Z agent: token created\n")
    port, data = free_port(), tmp / "data"
    agent = start_agent(port, data, tmp / "no-irpd.sock", "--agent-log", str(log))
    yield {"url": f"http://127.0.0.1:{port}", "token_file": str(data / "admin-token"), "tmp": tmp}
    stop(agent)


@pytest.fixture
def irpctl(live, capsys, monkeypatch):
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)

    def run(*argv: str) -> tuple[int, str, str]:
        capsys.readouterr()
        code = cli.main(["--url", live["url"], "--token-file", live["token_file"], *argv])
        out, err = capsys.readouterr()
        return code, out, err

    return run


def test_system_prints_the_figures(irpctl):
    code, out, err = irpctl("system")
    assert code == 0, err
    assert "agent" in out and "data folder" in out and "irpd" in out and "unreachable" in out
    code, out, _ = irpctl("--json", "system")
    assert code == 0 and json.loads(out)["agent"]["scheme"] == "http"


def test_backup_writes_the_archive_and_restore_dry_run_reviews_it(irpctl, live):
    target = live["tmp"] / "b.tar.gz"
    code, out, err = irpctl("backup", "-o", str(target))
    assert code == 0, err
    assert f"wrote {target}" in out
    with tarfile.open(target, "r:gz") as tar:
        assert tar.getnames()[0] == "manifest.json"
    code, out, err = irpctl("restore", str(target), "--dry-run")
    assert code == 0, err
    assert "dry run: nothing changed" in out and "tokens" in out and "tokens.json" in out
    code, out, _ = irpctl("--json", "restore", str(target), "--dry-run")
    assert json.loads(out)["dry_run"] is True
    folder = live["tmp"] / "backups"
    folder.mkdir()
    code, out, err = irpctl("backup", "-o", str(folder))  # a folder: the agent's file name in it
    assert code == 0, err
    assert [p.name.startswith("indurop-backup-") for p in folder.iterdir()] == [True]


def test_a_broken_archive_is_refused_with_exit_1_and_the_reason(irpctl, live):
    bad = live["tmp"] / "bad.tar.gz"
    bad.write_bytes(b"not an archive")
    code, _, err = irpctl("restore", str(bad), "--dry-run")
    assert code == 1 and "400" in err and "not a readable .tar.gz" in err


def test_sets_prune_dry_run_and_its_usage(irpctl):
    code, out, err = irpctl("sets", "prune", "--keep", "3", "--dry-run")
    assert code == 0, err
    assert out.startswith("would delete 0 set(s)")
    code, _, err = irpctl("sets", "prune")
    assert code == 2 and "--keep" in err
    code, _, err = irpctl("sets", "--keep", "2")
    assert code == 2 and "sets prune" in err
    code, _, err = irpctl("sets", "prune", "--keep", "-1")
    assert code == 2 and "0 or more" in err
    code, out, _ = irpctl("sets")  # still lists
    assert code == 0


def test_logs_read_and_search(irpctl):
    code, out, err = irpctl("logs", "agent")
    assert code == 0, err
    assert "agent: started" in out and "token created" in out
    code, out, _ = irpctl("logs", "agent", "--grep", "TOKEN")
    assert "token created" in out and "started" not in out
    code, out, _ = irpctl("logs", "agent", "--since", "2026-01-31T08:30")
    assert "token created" in out and "started" not in out
    code, _, err = irpctl("logs", "irpd")  # no file for irpd's log here
    if not logs.JOURNALD.is_dir():  # and no journald to read instead
        assert code == 1 and "--irpd-log" in err
    code, _, err = irpctl("logs", "kernel")
    assert code == 2
    code, _, err = irpctl("logs", "agent", "--since", "last tuesday")
    assert code == 2 and "not a time" in err


def test_restart_names_what_it_restarts(irpctl):
    code, _, err = irpctl("restart", "everything")
    assert code == 2
    code, _, err = irpctl("restart", "agent")  # no supervisor here
    assert code == 1 and "409" in err and "supervisor" in err
