"""status.py -- the running set: its status and its schedule (Table 3); the host's load.  Modules:
modules.py."""

from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from ...irpd import protocol
from ...irpd.client import IrpdRefused, IrpdUnavailable
from ..deps import IrpdDep, ViewerDep, ask
from ..models import HostLoad

router = APIRouter(tags=["status"])


@router.get("/status")
def status(irpd: IrpdDep, _: ViewerDep) -> protocol.Status:
    return ask(irpd, "status")


@router.get("/schedule")
def schedule(irpd: IrpdDep, _: ViewerDep) -> protocol.Schedule:
    return ask(irpd, "schedule")


@router.get("/host")
async def host(request: Request, irpd: IrpdDep, _: ViewerDep) -> HostLoad:
    """CPU load per CPU, load averages, and irpd's and the agent's CPU and memory, over the time
    since the previous GET /host (the first one samples 100 ms).  irpd is null when it does not
    answer or its process cannot be read."""
    try:
        pid = (await run_in_threadpool(irpd.request, "status")).get("pid")
    except (IrpdUnavailable, IrpdRefused):
        pid = None
    return await run_in_threadpool(request.app.state.host.load, pid if isinstance(pid, int) else None)
