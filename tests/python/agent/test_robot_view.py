"""test_robot_view.py -- the 3D robot view through the agent (docs/robot-view.md).

In process (no irpd): the viewer setting, robot.json in uploads, GET /robot without irpd, and the
proxy's door: no ticket, a bad one, a good one traded for a cookie, a cross-origin WebSocket.
Live, once per viewer (viser and meshcat): irpd running the PLC + robot cell (a copy of
build/sets/plc-robot on its own Modbus port), a real agent with --viewer, the viewer's page and
WebSocket through the agent's proxy, the scene's joint transforms followed while the cell runs its
pick-and-place cycle, every socket on 127.0.0.1, and PUT /robot/joints refusing bad maps and
storing a good one as a new set that keeps every module and drives the view."""

from __future__ import annotations

import asyncio
import json
import math
import os
import re
import shutil
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from agent_helpers import (
    BUILD,
    IRPD,
    ROOT,
    copy_cell,
    files_body,
    free_port,
    post_set,
    small_set,
    start_agent,
    start_irpd,
    stop,
)
from indurop_agent import config  # noqa: E402
from indurop_agent.viewer.mapping import parse_config  # noqa: E402
from indurop_agent.viewer.urdf import parse as parse_urdf  # noqa: E402
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

CELL = BUILD / "sets" / "plc-robot"
SOURCE = ROOT / "config" / "sets" / "plc-robot"
URDF = ROOT / "config" / "robots" / "indurop6.urdf"
NS = "PLC_ROBOT."
COOKIE = "indurop_viewer"


# ---- in process ---------------------------------------------------------------------------------
def test_the_viewer_is_a_setting_viser_by_default():
    assert config.parse([]).viewer == "viser"
    assert config.parse(["--viewer", "meshcat"]).viewer == "meshcat"
    with pytest.raises(SystemExit):
        config.parse(["--viewer", "vtk"])


def test_a_config_file_naming_an_unknown_viewer_is_refused(tmp_path, capsys):
    f = tmp_path / "agent.json"
    f.write_text(json.dumps({"viewer": "vtk"}))
    with pytest.raises(SystemExit):
        config.parse(["--config", str(f)])
    assert "viewer 'vtk' is not one of viser, meshcat" in capsys.readouterr().err


def robot_json(joint: str = "joint_1", urdf: str = "arm.urdf") -> bytes:
    return json.dumps({"urdf": urdf, "joints": [{"joint": joint, "variable": "V.x", "scale": 1, "offset": 0}]}).encode()


def test_a_set_holds_robot_json_as_its_own_kind(agent, elves):
    r = post_set(
        agent,
        *files_body(
            {**small_set(elves), "arm.urdf": URDF.read_bytes(), "robot.json": robot_json(), "more/robot.json": b"{}"}
        ),
    )
    assert r.status_code == 201, r.text
    kinds = {f["path"]: f["kind"] for f in r.json()["files"]}
    assert (kinds["robot.json"], kinds["arm.urdf"], kinds["more/robot.json"]) == ("robot", "urdf", "json")


@pytest.mark.parametrize(
    "files, words",
    [
        ({"robot.json": robot_json(), "arm.urdf": URDF.read_bytes()}, None),
        ({"robot.json": robot_json("joint_9"), "arm.urdf": URDF.read_bytes()}, '"joint_9" is not a joint of arm.urdf'),
        ({"robot.json": robot_json(urdf="missing.urdf")}, '"missing.urdf", which is not a .urdf file of the upload'),
        ({"robot.json": b'{"urdf": "arm.urdf"}', "arm.urdf": URDF.read_bytes()}, '"joints" must be a non-empty list'),
        ({"robot.json": robot_json(), "arm.urdf": b"<robot><link/></robot>"}, "a <link> without a name"),
    ],
    ids=["good", "unknown joint", "missing urdf", "no joints", "bad urdf"],
)
def test_an_upload_with_a_robot_json_that_does_not_fit_its_urdf_is_refused(agent, elves, files, words):
    r = post_set(agent, *files_body({**small_set(elves), **files}))
    if words is None:
        assert r.status_code == 201, r.text
    else:
        assert r.status_code == 400, r.text
        assert words in r.json()["detail"] and agent.stored() == []


def test_without_irpd_the_view_is_unavailable_and_says_why(agent):
    r = agent.client.get("/api/v1/robot", headers=agent.h("viewer"))
    assert r.status_code == 200, r.text
    view = r.json()
    assert (view["available"], view["viewer"], view["viewer_url"], view["joints"]) == (False, "viser", None, [])
    assert "irpd does not answer" in view["detail"]
    assert agent.client.get("/api/v1/robot/urdf", headers=agent.h("viewer")).status_code == 404
    body = {"joints": [{"joint": "joint_1", "variable": None, "scale": 1, "offset": 0}]}
    assert agent.client.put("/api/v1/robot/joints", json=body, headers=agent.h("operator")).status_code == 403
    r = agent.client.put("/api/v1/robot/joints", json=body, headers=agent.h("admin"))
    assert r.status_code == 409 and "no joint map to change" in r.json()["detail"]
    assert agent.audit()[-1]["action"] == "robot_joints" and agent.audit()[-1]["status"] == 409


def test_the_proxy_needs_a_ticket_and_trades_it_for_a_cookie(agent):
    client = agent.client
    r = client.get("/api/v1/robot/viewer/", follow_redirects=False)
    assert r.status_code == 401 and "viewer_url of GET /api/v1/robot" in r.json()["detail"]
    r = client.get("/api/v1/robot/viewer/?ticket=1.abc.def", follow_redirects=False)
    assert r.status_code == 401 and "not a viewer ticket" in r.json()["detail"]
    r = client.get("/api/v1/robot/viewer", follow_redirects=False)
    assert r.status_code == 307 and r.headers["location"] == "/api/v1/robot/viewer/"
    viewer = client.app.state.tokens.identify(agent.tokens["viewer"])
    ticket = client.app.state.tickets.issue(viewer)
    r = client.get(f"/api/v1/robot/viewer/?ticket={ticket}", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/api/v1/robot/viewer/"
    cookie = r.headers["set-cookie"]
    for attribute in ("HttpOnly", "Path=/api/v1/robot/viewer;", "SameSite=strict", "Max-Age=3600"):
        assert attribute in cookie, cookie
    assert "Secure" not in cookie  # plain HTTP here; with --tls-cert the cookie is Secure
    r = client.get("/api/v1/robot/viewer/", follow_redirects=False)  # the client kept the cookie
    assert r.status_code == 404 and "no 3D view" in r.json()["detail"]
    client.cookies.clear()
    assert client.get("/api/v1/robot/viewer/", follow_redirects=False).status_code == 401


def test_a_session_cookie_cannot_be_used_as_a_ticket_nor_forged(agent):
    client = agent.client
    viewer = client.app.state.tokens.identify(agent.tokens["viewer"])
    session = client.app.state.tickets.issue(viewer, "session")
    r = client.get(f"/api/v1/robot/viewer/?ticket={session}", follow_redirects=False)
    assert r.status_code == 401 and "signature" in r.json()["detail"]
    client.cookies.set(COOKIE, session[:-2] + "AA", path="/api/v1/robot/viewer")
    assert client.get("/api/v1/robot/viewer/", follow_redirects=False).status_code == 401


# ---- live: irpd running the cell, an agent per viewer ----------------------------------------------
def _cell_folder(tmp: Path) -> Path:
    """The built cell on its own Modbus port with room for a loaded machine's stalls (copy_cell),
    and the cell's robot.json (from the source tree if the build predates it)."""
    folder = tmp / "plc-robot"
    copy_cell(folder)
    if not (folder / "robot.json").exists():
        shutil.copy(SOURCE / "robot.json", folder / "robot.json")
    return folder


class Live:
    def __init__(self, tmp: Path, viewer: str):
        self.viewer = viewer
        self.folder = _cell_folder(tmp)
        self.sock, self.data = tmp / "irpd.sock", tmp / "data"
        # the drive simulator runs at SCHED_FIFO (the cell's module.xml): a loaded machine must not
        # fault the drives mid-motion
        self.irpd = start_irpd(self.sock, self.folder / "module.xml", f"robot-view-{viewer}-{os.getpid()}")
        self.port = free_port()
        cfg = tmp / "agent.json"
        cfg.write_text(json.dumps({"irpd_poll_s": 0.2}))
        self.agent = start_agent(self.port, self.data, self.sock, "--viewer", viewer, "--config", str(cfg))
        self.base = f"http://127.0.0.1:{self.port}"
        self.h = {"Authorization": f"Bearer {(self.data / 'admin-token').read_text().strip()}"}
        self.wait(lambda: self.get("/robot").json()["available"], "the view to come up")

    def get(self, path: str, **kw):
        return httpx.get(f"{self.base}/api/v1{path}", headers=self.h, timeout=60, **kw)

    def put(self, path: str, body):
        return httpx.put(f"{self.base}/api/v1{path}", headers=self.h, json=body, timeout=60)

    def write(self, path: str, value) -> None:
        r = self.put(f"/variables/{NS}{path}", {"value": value})
        assert r.status_code == 200, r.text

    def read(self, path: str):
        r = self.get(f"/variables/{NS}{path}")
        assert r.status_code == 200, r.text
        return r.json()["value"]

    @staticmethod
    def wait(what, doing: str, seconds: float = 30.0):
        deadline = time.monotonic() + seconds
        while not (value := what()):
            assert time.monotonic() < deadline, f"timed out waiting for {doing if isinstance(doing, str) else doing()}"
            time.sleep(0.05)
        return value

    def cookie(self) -> str:
        """The session cookie the proxy gives for GET /robot's viewer_url."""
        url = self.get("/robot").json()["viewer_url"]
        r = httpx.get(self.base + url, follow_redirects=False)
        assert r.status_code == 303, r.text
        return r.cookies[COOKIE]

    def joints(self) -> dict[str, float]:
        return {f"joint_{i + 1}": self.read(f"ROBOT_MODULE_STATE.dCurJoint[{i}]") for i in range(6)}

    def state(self) -> str:
        return ", ".join(
            f"{v}={self.read(v)}"
            for v in (
                "ROBOT_MODULE_STATE.eState",
                "ROBOT_MODULE_STATE.ErrorID",
                "PLC_OUT.ErrorID",
                "IO_STATUS.comm_lost[0]",
            )
        )

    def pulse(self, path: str) -> None:
        self.write(path, 0)
        time.sleep(0.1)  # ten periods: the PLC sees the 0 before the rising edge
        self.write(path, 1)

    def run_cycle(self, seconds: float = 30.0) -> None:
        """Power on, then the pick-and-place cycle, repeated until stopped.  A loaded test machine
        may stall the simulated drives long enough to count as lost communication (ErrorID 8): the
        PLC's Reset clears it and MC_Power powers on again, as an operator would do."""
        self.write("PLC_IN.Enable", 1)
        self.write("PLC_IN.CycleMode", 1)
        deadline = time.monotonic() + seconds
        while self.read("ROBOT_MODULE_STATE.eState") != 2:  # moving
            assert time.monotonic() < deadline, f"the robot does not move ({self.state()})"
            if self.read("ROBOT_MODULE_STATE.Error") or self.read("PLC_OUT.Error"):
                self.pulse("PLC_IN.Reset")
            elif self.read("ROBOT_MODULE_STATE.Powered") and not self.read("PLC_OUT.Running"):
                self.pulse("I0")
            time.sleep(0.5)

    def close(self) -> None:
        stop(self.agent)
        stop(self.irpd)


@pytest.fixture(scope="module", params=["viser", "meshcat"])
def live(request, tmp_path_factory):
    if not IRPD.exists() or not (CELL / "Robot.so").exists():
        pytest.skip(f"irpd and the plc-robot cell are not built ({BUILD})")
    pytest.importorskip(request.param)
    cell = Live(tmp_path_factory.mktemp(f"robot-{request.param}"), request.param)
    yield cell
    cell.close()


# The scene as each viewer's WebSocket describes it: {link: 4x4 pose relative to its parent (viser) or
# to the world (meshcat)}, from the messages received over `seconds`.
def _viser_messages(raw: bytes) -> list[dict]:
    import msgspec
    import zstandard

    size, packed = int.from_bytes(raw[:8], "little"), int.from_bytes(raw[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(raw[16 : 16 + packed], max_output_size=size)
    return msgspec.msgpack.decode(inner)["messages"]


def _quaternion_matrix(wxyz) -> np.ndarray:
    w, x, y, z = wxyz
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


async def _watch(live: Live, cookie: str, seconds: float, on_open=None) -> list[dict[str, np.ndarray]]:
    """Every scene state seen, after each message: link -> pose (as the viewer holds it)."""
    headers = {"Cookie": f"{COOKIE}={cookie}", "Origin": live.base}
    subprotocols = None
    if live.viewer == "viser":
        import viser

        subprotocols = [f"viser-v{viser.__version__}"]
    states, scene = [], {}
    async with connect(
        f"ws://127.0.0.1:{live.port}/api/v1/robot/viewer",
        additional_headers=headers,
        subprotocols=subprotocols,
        max_size=None,
        open_timeout=10,
    ) as ws:
        if live.viewer == "viser":
            assert ws.subprotocol == subprotocols[0]  # the viewer's choice, relayed by the proxy
        opener = asyncio.create_task(asyncio.to_thread(on_open or (lambda: None)))
        deadline = None
        while deadline is None or (left := deadline - time.monotonic()) > 0:
            if deadline is None and opener.done():
                opener.result()  # its failure, if any
                deadline, left = time.monotonic() + seconds, seconds
            elif deadline is None:
                left = 1.0
            try:
                raw = await asyncio.wait_for(ws.recv(), left)
            except TimeoutError:
                if deadline is None:
                    continue
                break
            if live.viewer == "viser":
                for m in _viser_messages(raw):
                    link = m.get("name", "").rsplit("/", 1)[-1]
                    if not m.get("name", "").startswith("/robot/visual/") or not link.startswith(("link_", "tool")):
                        continue
                    pose = scene.setdefault(link, np.eye(4)).copy()
                    if m["type"] == "SetOrientationMessage":
                        pose[:3, :3] = _quaternion_matrix(m["wxyz"])
                    elif m["type"] == "SetPositionMessage":
                        pose[:3, 3] = m["position"]
                    scene[link] = pose
            else:
                import umsgpack

                m = umsgpack.unpackb(raw)
                if m["type"] == "set_transform" and re.fullmatch(r"/meshcat/robot/[^/]+", m["path"]):
                    scene[m["path"].rsplit("/", 1)[-1]] = np.array(m["matrix"]).reshape(4, 4).T
            states.append(dict(scene))
    return states


def test_the_viewer_page_comes_through_the_proxy_with_a_ticket_only(live):
    view = live.get("/robot").json()
    assert view["viewer"] == live.viewer and view["available"], view
    url = view["viewer_url"]
    assert url.startswith("/api/v1/robot/viewer/?ticket=")
    assert httpx.get(f"{live.base}/api/v1/robot/viewer/").status_code == 401
    assert httpx.get(f"{live.base}/api/v1/robot/viewer/main.min.js").status_code == 401
    assert httpx.get(f"{live.base}/api/v1/robot/viewer/?ticket=0.000000000000.{'A' * 43}").status_code == 401
    with httpx.Client(base_url=live.base, follow_redirects=True) as browser:
        r = browser.get(url)  # 303 to the same page without the ticket, with the cookie
        assert r.status_code == 200 and r.url.path == "/api/v1/robot/viewer/" and "ticket" not in str(r.url)
        assert r.headers["content-type"].startswith("text/html")
        assert "frame-ancestors 'self'" in r.headers["content-security-policy"]  # the web UI frames it
        assert r.headers["x-frame-options"] == "SAMEORIGIN"
        if live.viewer == "viser":
            assert "<title>Viser</title>" in r.text
        else:
            assert "MeshCat.Viewer" in r.text and "viewer.connect(location.href" in r.text
            js = browser.get("/api/v1/robot/viewer/main.min.js")
            assert js.status_code == 200 and "javascript" in js.headers["content-type"] and len(js.content) > 100_000
        assert browser.get("/api/v1/robot/viewer/..%2F..%2Fetc/passwd").status_code == 404


def test_the_viewer_websocket_needs_the_cookie_and_the_pages_own_origin(live):
    async def refused(headers):
        with pytest.raises(InvalidStatus) as e:
            async with connect(
                f"ws://127.0.0.1:{live.port}/api/v1/robot/viewer", additional_headers=headers, open_timeout=10
            ):
                pass
        return e.value.response.status_code

    cookie = live.cookie()
    assert asyncio.run(refused({})) == 403
    assert asyncio.run(refused({"Cookie": f"{COOKIE}=1.abc.def"})) == 403
    assert asyncio.run(refused({"Cookie": f"{COOKIE}={cookie}", "Origin": "http://evil.example"})) == 403


CHAIN = ["link_1", "link_2", "link_3", "link_4", "link_5", "link_6", "tool0"]


def world(live: Live, scene: dict[str, np.ndarray], link: str) -> np.ndarray:
    """A link's world pose in the scene: meshcat holds world poses, viser each link in its parent."""
    if live.viewer == "meshcat":
        return scene[link]
    pose = np.eye(4)
    for name in CHAIN[: CHAIN.index(link) + 1]:
        pose = pose @ scene[name]
    return pose


def test_the_scene_follows_the_joints_while_the_cell_runs(live):
    # 30 poses a second while moving.  A loaded machine may fault the cell mid-motion (lost
    # communication with the simulated drives): a window in which the cell stopped on an error
    # proves nothing either way and is watched again, after run_cycle's reset; a scene that did
    # not follow a cell that kept running fails at once.
    for attempt in range(3):  # noqa: B007 -- named in the assertion after the loop
        states = asyncio.run(_watch(live, live.cookie(), 8.0, on_open=live.run_cycle))
        assert states, "no scene from the viewer"
        tool = {tuple(np.round(world(live, s, "tool0"), 6).ravel()) for s in states if set(CHAIN) <= set(s)}
        faulted = live.read("PLC_OUT.Error") or live.read("ROBOT_MODULE_STATE.Error")
        if len(tool) >= 10 or not faulted:
            break
    assert len(tool) >= 10, f"{len(tool)} poses of tool0 in 8 s of motion ({live.state()}, attempt {attempt + 1})"

    # Stopped, the scene holds the measured joints: tool0 where FK puts it (a new client gets the
    # scene as it is now).  Steady joints are enough: a loaded machine may have stopped the cell with
    # a communication error meanwhile, which holds the drives where they are too.  The scene is
    # compared with the joints read before and after it (a window in which any joint changed is taken
    # again), to within one count of the drives (1e-5 rad, so 3e-5 m at the tool's reach): a count
    # that comes and goes between two reads of the API may still be in the scene.
    live.write("I1", 1)
    try:

        def scene_between_equal_joints():
            before = live.joints()
            time.sleep(0.5)
            scene = asyncio.run(_watch(live, live.cookie(), 1.5))[-1]
            return (before, scene) if live.joints() == before else None

        q, scene = live.wait(scene_between_equal_joints, "the joints to stand still around a scene", 60.0)
        expected = parse_urdf(URDF).fk(q)
        for link in CHAIN:
            np.testing.assert_allclose(world(live, scene, link), expected[link], rtol=0, atol=3e-5, err_msg=link)
    finally:
        live.write("I1", 0)


def test_get_robot_shows_the_sets_map_and_the_urdf(live):
    view = live.get("/robot").json()
    assert view["urdf"] == "indurop6.urdf" and view["detail"] is None
    assert [(j["joint"], j["variable"], j["scale"], j["offset"], j["type"]) for j in view["joints"]] == [
        (f"joint_{i + 1}", f"{NS}ROBOT_MODULE_STATE.dCurJoint[{i}]", 1.0, 0.0, "revolute") for i in range(6)
    ]
    assert (view["joints"][1]["lower"], view["joints"][1]["upper"]) == (-1.745, 2.356)
    r = live.get("/robot/urdf")
    assert r.status_code == 200 and r.headers["content-type"] == "application/xml"
    assert r.content == URDF.read_bytes()


def _listening(pid: int) -> set[str]:
    """The local addresses of the TCP sockets a process and its children listen on."""

    def inodes(p):
        out = set()
        for fd in Path(f"/proc/{p}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                out.add(target[8:-1])
        return out

    pids = [pid]
    for task in Path(f"/proc/{pid}/task").iterdir():
        pids += [int(c) for c in (task / "children").read_text().split()]
    mine = set().union(*(inodes(p) for p in pids))
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            f = line.split()
            if f[3] == "0A" and f[9] in mine:  # LISTEN
                address = f[1].split(":")[0]
                found.add(
                    ".".join(str(int(address[i : i + 2], 16)) for i in (6, 4, 2, 0)) if len(address) == 8 else address
                )
    return found


def test_the_agent_and_its_viewer_listen_on_loopback_only(live):
    addresses = _listening(live.agent.pid)
    assert addresses == {"127.0.0.1"}, addresses
    if live.viewer == "meshcat":  # the viewer's server is a child process of the agent
        children = [
            int(c) for t in Path(f"/proc/{live.agent.pid}/task").iterdir() for c in (t / "children").read_text().split()
        ]
        assert children, "the meshcat server is not the agent's child"


def test_put_joints_refuses_a_bad_map_naming_the_entry(live):
    good = {"joint": "joint_1", "variable": f"{NS}ROBOT_MODULE_STATE.dCurJoint[0]", "scale": 1, "offset": 0}
    cases = [
        ({"joints": [{**good, "joint": "joint_9"}]}, 'joints[0].joint "joint_9" is not a joint of indurop6.urdf'),
        ({"joints": [good, {**good, "joint": "joint_tool0"}]}, 'joints[1].joint "joint_tool0" is a fixed joint'),
        ({"joints": [{**good, "variable": f"{NS}NOPE"}]}, f"no variable '{NS}NOPE' in the running layout"),
        ({"joints": [{**good, "variable": f"{NS}ROBOT_MODULE_STATE.dCurJoint"}]}, "not a scalar"),
        ({"joints": [good, good]}, 'joints[1].joint "joint_1" is mapped twice'),
    ]
    sets_before = live.get("/sets").json()
    for body, words in cases:
        r = live.put("/robot/joints", body)
        assert r.status_code == 400, r.text
        assert words in r.json()["detail"], r.json()["detail"]
    assert live.put("/robot/joints", {"joints": []}).status_code == 422
    assert live.get("/sets").json() == sets_before  # nothing stored
    assert live.get("/robot").json()["joints"][0]["variable"] == good["variable"]


def test_put_joints_stores_a_new_set_keeps_every_module_and_drives_the_view(live):
    status = live.get("/status").json()
    modules_before = {m["name"]: m["runs"] for m in live.get("/modules").json()}
    override = f"{NS}PLC_IN.Override"
    body = {
        "joints": [
            {"joint": "joint_1", "variable": override, "scale": 2.0, "offset": 0.25},
            {"joint": "joint_2", "variable": f"{NS}ROBOT_MODULE_STATE.dCurJoint[1]", "scale": 1, "offset": 0},
        ]
    }
    r = live.put("/robot/joints", body)
    assert r.status_code == 200, r.text
    view = r.json()
    new_id = view["set_id"]
    after = live.get("/status").json()
    assert new_id and after["set_id"] == new_id and after["generation"] == status["generation"] + 1
    assert view["available"] and view["viewer_url"]
    assert [(j["joint"], j["variable"], j["scale"], j["offset"]) for j in view["joints"]] == [
        ("joint_1", override, 2.0, 0.25),
        ("joint_2", f"{NS}ROBOT_MODULE_STATE.dCurJoint[1]", 1.0, 0.0),
        *((f"joint_{i}", None, 1.0, 0.0) for i in range(3, 7)),
    ]
    # Stored like any set: robot.json replaced, every other file the running one's.
    stored = live.get(f"/sets/{new_id}").json()
    assert stored["active"] and {f["path"]: f["kind"] for f in stored["files"]}["robot.json"] == "robot"
    files = Path(after["set"]).parent
    config = parse_config((files / "robot.json").read_bytes())
    assert config.joints[0].variable == override and config.description
    assert (files / "Robot.so").read_bytes() == (live.folder / "Robot.so").read_bytes()
    # The hot reload kept every module: their run counts went on.
    audit = [e for e in live.get("/audit").json() if e["action"] == "robot_joints" and e["result"] == "ok"][-1]
    assert sorted(audit["kept"]) == sorted(modules_before) and audit["target"] == new_id
    assert audit["imported"] is (status["set_id"] is None)
    for m in live.get("/modules").json():
        assert m["runs"] >= modules_before[m["name"]], m["name"]
    events = live.get("/events?since=0&agent_since=0&limit=500").json()["events"]
    assert any(e["kind"] == "robot_joints" and new_id in e["message"] for e in events)

    # The view now takes joint_1 from the override: 0.3 * 2 + 0.25 = 0.85 rad about z, joints 3..6 at 0.
    live.write("PLC_IN.Override", 0.3)
    states = asyncio.run(_watch(live, live.cookie(), 3.0))
    link1 = states[-1]["link_1"]
    assert math.isclose(math.atan2(link1[1, 0], link1[0, 0]), 0.85, abs_tol=1e-6), link1
    if live.viewer == "meshcat":
        link4 = np.linalg.inv(states[-1]["link_3"]) @ states[-1]["link_4"]
    else:
        link4 = states[-1]["link_4"]
    np.testing.assert_allclose(link4[:3, :3], np.eye(3), atol=1e-9)  # joint_4 held at 0

    # The same map again is the same set: nothing new, nothing reloaded.
    again = live.put("/robot/joints", body)
    assert again.status_code == 200 and again.json()["set_id"] == new_id
    assert live.get("/status").json()["generation"] == after["generation"]


def test_a_set_without_robot_json_makes_the_view_unavailable_and_rollback_brings_it_back(live):
    active = live.get("/sets/active").json()
    files = Path(live.get("/status").json()["set"]).parent
    parts = [
        ("files", (p.relative_to(files).as_posix(), p.read_bytes()))
        for p in sorted(files.rglob("*"))
        if p.is_file() and p.name != "robot.json"
    ]
    r = httpx.post(f"{live.base}/api/v1/sets", headers=live.h, files=parts, timeout=60)
    assert r.status_code == 201, r.text
    bare = r.json()["id"]
    assert httpx.post(f"{live.base}/api/v1/sets/{bare}/activate", headers=live.h, timeout=60).status_code == 200
    view = live.wait(lambda: (v := live.get("/robot").json()) and not v["available"] and v, "the view to go")
    assert "has no robot.json" in view["detail"] and view["viewer_url"] is None
    assert live.put("/robot/joints", {"joints": [{"joint": "joint_1", "variable": None}]}).status_code == 409
    assert httpx.post(f"{live.base}/api/v1/sets/rollback", headers=live.h, timeout=60).status_code == 200
    view = live.wait(lambda: (v := live.get("/robot").json())["available"] and v, "the view to come back")
    assert view["set_id"] == active["id"] and view["joints"][0]["scale"] == 2.0


def test_a_hot_reload_that_keeps_the_robot_keeps_the_scene(live):
    """A period or priority change swaps the set, not the robot: the viewer keeps its scene (no
    flicker, no scene rebuilt every reload); a new robot.json loads the robot again."""

    def robot_views() -> int:
        events = live.get("/events?since=0&agent_since=0&limit=1000").json()["events"]
        return sum(e["kind"] == "robot_view" for e in events)

    def view_follows(set_id):
        return live.wait(
            lambda: (v := live.get("/robot").json())["set_id"] == set_id and v["available"] and v,
            f"the view to follow set {set_id}",
        )

    view_follows(live.get("/status").json()["set_id"])
    shown = robot_views()
    main = live.get("/modules/main").json()
    r = httpx.patch(
        f"{live.base}/api/v1/modules/main", headers=live.h, json={"priority": main["priority"] + 1}, timeout=60
    )
    assert r.status_code == 200, r.text
    swapped = live.get("/status").json()
    view_follows(swapped["set_id"])
    time.sleep(1.0)  # two of the view's status checks
    assert robot_views() == shown
    tool = world(live, asyncio.run(_watch(live, live.cookie(), 1.0))[-1], "tool0")
    assert np.isfinite(tool).all()  # the kept scene still answers a new client with the robot

    view = live.get("/robot").json()
    body = {
        "joints": [
            {"joint": j["joint"], "variable": j["variable"], "scale": j["scale"] * 1.5, "offset": j["offset"]}
            for j in view["joints"][:1]
        ]
    }
    r = live.put("/robot/joints", body)
    assert r.status_code == 200, r.text
    view_follows(r.json()["set_id"])
    assert robot_views() == shown + 1
