"""audit.py -- GET /api/v1/audit (admin): the last lines of the audit log, oldest first."""

from fastapi import APIRouter, Query, Request

from ..deps import AdminDep

router = APIRouter(tags=["audit"])


@router.get("/audit")
def audit(request: Request, _: AdminDep, limit: int = Query(100, ge=1, le=10000)) -> list[dict]:
    """Each entry: time, who {id, name, role}, client, action, target, result (ok | error), and
    status/detail for errors, files {path: sha256} for uploads.  See docs/set-store.md."""
    request.app.state.refusals.flush()  # the suppressed refusals' count, before it is read
    return request.app.state.audit.tail(limit)
