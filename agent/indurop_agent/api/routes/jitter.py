"""jitter.py -- GET /api/v1/jitter: the timing figures of every dispatcher and module (Eq. (1)
jitter, wake-up/start latency, execution time as p50/p99/p99.9/max, overruns, misses)."""
from fastapi import APIRouter

from ..deps import IrpdDep, ViewerDep, ask

router = APIRouter(tags=["jitter"])


@router.get("/jitter")
def jitter(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "stats")
