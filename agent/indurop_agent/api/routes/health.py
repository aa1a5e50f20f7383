"""health.py -- GET /api/v1/health: is the agent up, and does irpd answer (no token needed)."""

from fastapi import APIRouter

from ... import __version__
from ...irpd.client import IrpdRefused, IrpdUnavailable
from ..deps import IrpdDep
from ..models import Health

router = APIRouter(tags=["health"])


# shorter than the clients' probe (the web UI gives up after 2.5 s), so a stopped irpd is reported
# as "irpd unreachable" and not mistaken for an agent that does not answer
HEALTH_TIMEOUT_S = 1.0


@router.get("/health")
def health(irpd: IrpdDep) -> Health:
    try:
        status = irpd.request("status", timeout=HEALTH_TIMEOUT_S)
        return {"agent": "ok", "version": __version__, "irpd": "ok", "running": status.get("running", False)}
    except (IrpdUnavailable, IrpdRefused) as e:
        return {"agent": "ok", "version": __version__, "irpd": "unreachable", "detail": str(e)}
