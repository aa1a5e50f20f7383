"""acks.py -- Acknowledge and Confirm over OPC UA (docs/opcua.md "Alarms"): the methods of
AcknowledgeableConditionType, called on an alarm's ConditionId with an EventId of that condition
and a comment, go to the agent, which owns the alarms' acknowledgement (its alarm manager and
SQLite store, the same state as the web UI's).

The server calls the agent's /opcua/alarms routes (api/routes/opcua_alarms.py) at `agent_url`,
with its own token (<data>/opcua-token, link.py) and the session's user, how it signed in, its
role, session id and client address; the agent checks the user's role (operator or more), audits
the change as that user via opcua, and answers the alarm as it is now.  Its GET /opcua/alarms gives
the states the events' AckedState and ConfirmedState follow, also after an acknowledgement in the
web UI (alarms.py asks it every ACK_POLL_S)."""

from __future__ import annotations

import logging
import ssl
from urllib.parse import quote

import httpx
from asyncua import ua

from ..api.opcua_models import MAX_COMMENT
from .link import read_token
from .settings import OpcuaSettings

_logger = logging.getLogger(__name__)
ACKNOWLEDGE = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
CONFIRM = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Confirm)
METHODS = {ACKNOWLEDGE: "ack", CONFIRM: "confirm"}
REFUSED = {  # the agent's answer -> the method's status
    403: ua.StatusCodes.BadUserAccessDenied,
    404: ua.StatusCodes.BadNodeIdUnknown,  # the agent holds no such alarm (it is normal)
    409: {
        "ack": ua.StatusCodes.BadConditionBranchAlreadyAcked,
        "confirm": ua.StatusCodes.BadConditionBranchAlreadyConfirmed,
    },
}


class AgentUnavailable(Exception):
    pass


class AgentAlarms:
    """The agent's alarm routes for the server."""

    def __init__(self, settings: OpcuaSettings):
        self.settings = settings
        self.client = httpx.AsyncClient(
            base_url=settings.agent_url.rstrip("/") + "/api/v1",
            verify=ssl.create_default_context(cafile=settings.agent_ca or None),
            timeout=5.0,
        )

    def _headers(self) -> dict:
        token = read_token(self.settings.data_dir)
        if token is None:
            raise AgentUnavailable(f"no {self.settings.data_dir}/opcua-token: has the agent run with this data folder?")
        return {"Authorization": f"Bearer {token}"}

    async def states(self) -> dict[str, dict]:
        """The alarms the agent holds (not normal), by key."""
        try:
            r = await self.client.get("/opcua/alarms", headers=self._headers())
        except httpx.HTTPError as e:
            raise AgentUnavailable(f"{self.settings.agent_url}: {e}") from e
        if r.status_code != 200:
            raise AgentUnavailable(f"{self.settings.agent_url}: GET /opcua/alarms answered {r.status_code}")
        return {a["key"]: a for a in r.json()["alarms"]}

    async def act(self, action: str, key: str, session, comment: str) -> tuple[int, dict | None]:
        """The session's Acknowledge ("ack") or Confirm ("confirm") of `key`: (OPC UA status, the
        alarm as the agent has it now or None)."""
        user = session.user
        peer = session.name if isinstance(session.name, tuple) else ("unknown", 0)
        body = {
            "user": getattr(user, "name", None) or "anonymous",
            "method": getattr(user, "via", "anonymous"),
            "role": getattr(user, "agent_role", "viewer"),
            "session": f"opcua-session-{session.session_id.Identifier}",
            "client": str(peer[0]),
            "comment": comment[:MAX_COMMENT],
        }
        try:
            r = await self.client.post(
                f"/opcua/alarms/{quote(key, safe='/')}/{action}", json=body, headers=self._headers()
            )
        except (httpx.HTTPError, AgentUnavailable) as e:
            _logger.warning("%s of %s: the agent did not answer: %s", action, key, e)
            return ua.StatusCodes.BadCommunicationError, None
        if r.status_code == 200:
            return ua.StatusCodes.Good, r.json()
        refused = REFUSED.get(r.status_code)
        if refused is None:
            _logger.warning("%s of %s: the agent answered %s: %s", action, key, r.status_code, r.text[:200])
            return ua.StatusCodes.BadCommunicationError, None
        return (refused[action] if isinstance(refused, dict) else refused), None

    async def close(self) -> None:
        await self.client.aclose()
