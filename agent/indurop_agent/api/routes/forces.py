"""forces.py -- GET /api/v1/forces (the variables irpd holds forced, who forced them and when),
PUT /api/v1/forces/{path} (operator: force a leaf to a value; `by` is the signed-in user) and
DELETE /api/v1/forces/{path}?restore= (unforce, keeping the forced value or restoring the one
before).  Every force and unforce is audited.  docs/forcing.md."""

from fastapi import APIRouter, Query, Request
from pydantic import BaseModel, ConfigDict

from ...irpd import protocol
from ..deps import IrpdDep, OperatorDep, ViewerDep, ask, audited

router = APIRouter(tags=["forces"])


def forced_paths(irpd, status: dict) -> dict[str, dict]:
    """{path: force entry} of the variables forced now; irpd is asked for them only when its
    `status` (asked already by the caller) says some are."""
    if not status.get("forces"):
        return {}
    return forced_now(irpd)


def forced_now(irpd) -> dict[str, dict]:
    """{path: force entry} of the variables forced now: irpd's `forces`, one small answer (a
    caller that needs no `status` asks this alone)."""
    return {f["path"]: f for f in ask(irpd, "forces")["forces"]}


class ForceRequest(BaseModel):
    """The value to hold: irpd checks it against the variable's type and range (409 with its message)."""

    model_config = ConfigDict(extra="forbid")
    value: protocol.VariableValue


@router.get("/forces")
def list_forces(irpd: IrpdDep, _: ViewerDep) -> protocol.ForceList:
    return ask(irpd, "forces")


@router.put(
    "/forces/{path:path}",
    responses={409: {"description": "irpd refused: unknown path, a struct or array as a whole, wrong type, too many"}},
)
def force_variable(path: str, body: ForceRequest, request: Request, irpd: IrpdDep, who: OperatorDep) -> protocol.Force:
    """Holds the leaf `path` (a scalar, a struct member or an array element) at `value` for every
    reader in every period, whatever modules write, until it is unforced."""
    by = (who.user or who.name)[: protocol.MAX_NAME_LENGTH]
    with audited(request, who, "force", path, value=body.value):
        return ask(irpd, "force", path=path, value=body.value, by=by)


@router.delete(
    "/forces/{path:path}",
    responses={404: {"description": "the variable is not forced (the forced ones are named)"}},
)
def unforce_variable(
    path: str,
    request: Request,
    irpd: IrpdDep,
    who: OperatorDep,
    restore: bool = Query(False, description="true: write back the value it had before the force"),
) -> protocol.Unforced:
    with audited(request, who, "unforce", path, restore=restore) as entry:
        answer = ask(irpd, "unforce", path=path, restore=restore)
        entry["left"] = answer.get("left")
        return answer
