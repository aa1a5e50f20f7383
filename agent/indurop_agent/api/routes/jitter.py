"""jitter.py -- GET /api/v1/jitter: the timing figures of every dispatcher and module (Eq. (1)
jitter, wake-up/start latency, execution time as p50/p99/p99.9/max, overruns, misses), and
GET /api/v1/jitter/histograms: the histograms behind them, bucket by bucket."""

from fastapi import APIRouter, Query

from ...irpd import protocol
from ..deps import IrpdDep, ViewerDep, ask
from ..models import Histograms

router = APIRouter(tags=["jitter"])


@router.get("/jitter")
def jitter(irpd: IrpdDep, _: ViewerDep) -> protocol.Stats:
    return ask(irpd, "stats")


def _histogram(h: dict) -> dict:
    return {
        "count": h["count"],
        "min": h["min"],
        "max": h["max"],
        "buckets": [{"low_ns": low, "width_ns": width, "count": n} for low, width, n in h["buckets"]],
    }


@router.get("/jitter/histograms", responses={404: {"description": "no dispatcher or module of that name"}})
def histograms(
    irpd: IrpdDep,
    _: ViewerDep,
    name: str | None = Query(
        None,
        min_length=1,
        max_length=protocol.MAX_NAME_LENGTH,
        description="one dispatcher's or module's name; all when absent",
    ),
) -> Histograms:
    """The histograms behind GET /jitter (non-empty buckets), of one record by name or of all,
    cumulative since irpd started: difference two answers for the figures of the time between."""
    result = ask(irpd, "histograms", **({"name": name} if name is not None else {}))
    for r in result["records"]:
        for key in ("jitter_ns", "latency_ns", "exec_ns"):
            r[key] = _histogram(r[key])
    return result
