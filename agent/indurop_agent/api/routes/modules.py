"""modules.py -- the running set's modules: every one with live figures, one by name, PATCH of a
module's period, priority or enabled state (each a hot swap in irpd), and POST /modules/changes:
several modules changed as one hot swap, or only tried (dry run).  The bodies' types and ranges
are the control protocol's (protocol/control.json); everything else about a change (a module the
set lacks, one named twice, a period below the minimum) is irpd's to refuse, and its answer is
passed on."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request

from ...irpd import protocol
from ..deps import IrpdDep, OperatorDep, SwapIrpdDep, ViewerDep, ask, audited
from ..models import ChangesReport, ErrorBody, ModuleChanges, PatchReport

router = APIRouter(tags=["modules"])


class ModulePatch(protocol.ModuleValues):
    """A module's new period, priority or enabled state: at least one."""


@router.get("/modules")
def modules(irpd: IrpdDep, _: ViewerDep) -> list[protocol.ModuleInfo]:
    return ask(irpd, "modules")


def _find(irpd, name: str) -> dict:
    for m in ask(irpd, "modules"):
        if m.get("name") == name:
            return m
    raise HTTPException(404, f"no module {name!r} in the running set; GET /api/v1/modules lists them")


@router.get("/modules/{name}", responses={404: {"description": "no such module in the running set"}})
def module(name: str, irpd: IrpdDep, _: ViewerDep) -> protocol.ModuleInfo:
    return _find(irpd, name)


@router.patch(
    "/modules/{name}",
    responses={
        404: {"description": "no such module in the running set"},
        409: {"description": "irpd refused a change (its message)"},
    },
)
def patch_module(name: str, body: ModulePatch, request: Request, swap: SwapIrpdDep, who: OperatorDep) -> PatchReport:
    """Applies period_ns, then priority, then enabled, each as one swap; answers the last swap
    report with every report in `reports`.  If a later one is refused, the earlier ones stay
    applied and the 409 says which."""
    timeout = request.app.state.settings.swap_timeout_s
    changes = body.model_dump(exclude_none=True)
    with audited(request, who, "patch_module", name, changes=changes) as entry:
        steps = []
        if body.period_ns is not None:
            steps.append(("period_ns", "set_period", {"period_ns": body.period_ns}))
        if body.priority is not None:
            steps.append(("priority", "set_priority", {"priority": body.priority}))
        if body.enabled is not None:
            steps.append(("enabled", "enable" if body.enabled else "disable", {}))
        reports, applied = [], []
        for field, cmd, args in steps:
            try:
                reports.append(ask(swap, cmd, module=name, timeout=timeout, **args) or {})
            except HTTPException as e:
                done = f"; already applied: {', '.join(applied)}" if applied else "; nothing was changed"
                raise HTTPException(e.status_code, f"{field}: {e.detail}{done}") from e
            applied.append(field)
        entry["generation"] = reports[-1].get("generation")
    request.app.state.events.add("patch_module", f"module {name}: {changes} by {who.name}", module=name)
    return PatchReport(**reports[-1], reports=reports)


@router.post(
    "/modules/changes",
    responses={
        404: {"model": ErrorBody, "description": "a module not in the running set"},
        409: {
            "model": ErrorBody,
            "description": "irpd refused the changes (its message: a module twice, a period below the minimum, ...)",
        },
    },
)
def change_modules(body: ModuleChanges, request: Request, swap: SwapIrpdDep, who: OperatorDep) -> ChangesReport:
    """Several modules' period, priority or enabled changed in one hot swap (one new generation);
    with dry_run, the same checks and the slot table before and after with the estimated
    utilization, nothing changed.  `before` is the table running when irpd took the request.
    Real runs are audited (change_modules) and an agent event; dry runs are neither."""
    changes = [{"module": c.name, **c.model_dump(exclude_none=True, exclude={"name"})} for c in body.changes]
    timeout = request.app.state.settings.swap_timeout_s
    if body.dry_run:
        result = ask(swap, "change", changes=changes, dry_run=True, timeout=timeout)
    else:
        names = ", ".join(c.name for c in body.changes)
        with audited(request, who, "change_modules", names, changes=changes) as entry:
            result = ask(swap, "change", changes=changes, dry_run=False, timeout=timeout)
            entry["generation"] = (result.get("report") or {}).get("generation")
        request.app.state.events.add(
            "change_modules",
            f"modules {names}: {changes} by {who.name} (generation {entry['generation']})",
            module=body.changes[0].name if len(body.changes) == 1 else None,
        )
    per_executor = {k: float(v) for k, v in (result.get("utilization") or {}).items()}
    return ChangesReport(
        dry_run=body.dry_run,
        before=result["before"],
        after=result["schedule"],
        utilization=max(per_executor.values(), default=0.0),
        executors=per_executor,
        warnings=result.get("warnings") or [],
        report=result.get("report"),
    )
