"""opcua_read.py -- reads shared variables from indurop-opcua as an outside OPC UA client would (asyncua,
Basic256Sha256 SignAndEncrypt, a client certificate the server trusts, signed in as an agent user),
for the browser tests that check what a page did also from OPC UA.  Prints one JSON object: each
path's value and the node's Description.

    opcua_read.py URL DATA_DIR USER PASSWORD PATH...   (DATA_DIR: the agent's, which the server uses)
"""

from __future__ import annotations

import asyncio
import json
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python" / "opcua"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from asyncua import Client, ua  # noqa: E402
from opcua_helpers import POLICIES, make_client_certificate, ns_of  # noqa: E402

URI = "urn:indurop:test:browser"


async def read(url: str, data: Path, user: str, password: str, paths: list[str]) -> dict:
    work = Path(tempfile.mkdtemp(prefix="indurop-opcua-read-"))
    key, cert = work / "key.pem", work / "cert.der"
    await make_client_certificate(key, cert, URI)
    shutil.copy(cert, data / "opcua" / "pki" / "trusted" / f"browser-test-{work.name}.der")
    c = Client(url, timeout=30)
    c.application_uri = URI
    c.set_user(user)
    c.set_password(password)
    await c.set_security(POLICIES["Basic256Sha256"], str(cert), str(key), mode=ua.MessageSecurityMode.SignAndEncrypt)
    c.user_certificate, c.user_private_key = None, None  # sign in with the user name, not the certificate
    out = {}
    for _ in range(100):  # the server takes a trusted certificate on its next look at the folder
        try:
            await c.connect()
            break
        except Exception:  # refused until then
            await asyncio.sleep(0.2)
    else:
        await c.connect()
    try:
        ns = await ns_of(c)
        for path in paths:
            node = c.get_node(ua.NodeId(path, ns))
            out[path] = {"value": await node.read_value(), "description": (await node.read_description()).Text}
    finally:
        await c.disconnect()
        shutil.rmtree(work, ignore_errors=True)
    return out


if __name__ == "__main__":
    url, data, user, password, *paths = sys.argv[1:]
    print(json.dumps(asyncio.run(read(url, Path(data), user, password, paths))))
