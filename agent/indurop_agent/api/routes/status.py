"""status.py -- the running set: its status and its schedule (Table 3).  Modules: modules.py."""
from fastapi import APIRouter

from ..deps import IrpdDep, ViewerDep, ask

router = APIRouter(tags=["status"])


@router.get("/status")
def status(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "status")


@router.get("/schedule")
def schedule(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "schedule")
