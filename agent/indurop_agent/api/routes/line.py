"""line.py -- GET /api/v1/line: the controllers this controller's DDS bridge sees on its domain,
with their state and their web UI's address (docs/dds.md "The line").  The bridge writes the view
to a file (the agent owns no DDS participant); an absent or old file says the bridge is off."""

from fastapi import APIRouter, Request

from ...dds.line_view import LineView, read_view
from ..deps import ViewerDep

router = APIRouter(tags=["line"])


@router.get("/line")
def line(request: Request, _: ViewerDep) -> LineView:
    """Every controller on the line (this one included, `this`), sorted by name: ok, warning, fault
    or lost, with why; `bridge` says whether the view is current."""
    return read_view(request.app.state.settings.line_file)
