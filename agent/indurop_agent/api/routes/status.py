"""status.py -- the running set: its status and its schedule (Table 3); the host's load.  Modules:
modules.py."""
from fastapi import APIRouter

from ..deps import IrpdDep, ViewerDep, ask
from ..models import HostLoad

router = APIRouter(tags=["status"])


@router.get("/status")
def status(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "status")


@router.get("/schedule")
def schedule(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "schedule")


@router.get("/host")
def host(irpd: IrpdDep, _: ViewerDep) -> HostLoad:
    """CPU load per CPU, load averages, and irpd's and the agent's CPU and memory."""
    raise NotImplementedError
