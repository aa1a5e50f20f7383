"""health.py -- GET /api/v1/health: is the agent up, and does irpd answer (no token needed)."""
from fastapi import APIRouter

from ... import __version__
from ...irpd_client import IrpdRefused, IrpdUnavailable
from ..deps import IrpdDep
from ..models import Health

router = APIRouter(tags=["health"])


@router.get("/health")
def health(irpd: IrpdDep) -> Health:
    try:
        status = irpd.request("status")
        return {"agent": "ok", "version": __version__, "irpd": "ok", "running": status.get("running", False)}
    except (IrpdUnavailable, IrpdRefused) as e:
        return {"agent": "ok", "version": __version__, "irpd": "unreachable", "detail": str(e)}
