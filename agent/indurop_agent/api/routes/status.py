"""status.py -- the running set: status, its schedule (Table 3), its modules with live figures."""
from fastapi import APIRouter

from ..deps import IrpdDep, ViewerDep, ask

router = APIRouter(tags=["status"])


@router.get("/status")
def status(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "status")


@router.get("/schedule")
def schedule(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "schedule")


@router.get("/modules")
def modules(irpd: IrpdDep, _: ViewerDep) -> list:
    return ask(irpd, "modules")
