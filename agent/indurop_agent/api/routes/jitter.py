"""jitter.py -- GET /api/v1/jitter: the timing figures of every dispatcher and module (Eq. (1)
jitter, wake-up/start latency, execution time as p50/p99/p99.9/max, overruns, misses)."""
from fastapi import APIRouter

from ..deps import IrpdDep, ViewerDep, ask
from ..models import Histograms

router = APIRouter(tags=["jitter"])


@router.get("/jitter")
def jitter(irpd: IrpdDep, _: ViewerDep) -> dict:
    return ask(irpd, "stats")


@router.get("/jitter/histograms")
def histograms(irpd: IrpdDep, _: ViewerDep, name: str | None = None) -> Histograms:
    """The histograms behind GET /jitter (non-empty buckets), of one record by name or of all."""
    raise NotImplementedError
