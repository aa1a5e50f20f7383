"""watch_lists.py -- the watch lists kept beside a stored set (docs/programming.md "Watch lists"):
<data>/sets/<id>/watches/<name>.json, each the variable paths the Watch page shows live.  Stored as
every file kept with a set is (sets/kept.py): in backups, and copied to a set derived by an edit."""

from __future__ import annotations

from ..api.monitor_models import MAX_WATCH_BYTES, MAX_WATCHES, WatchList
from .kept import Kept


class WatchLists(Kept):
    FOLDER = "watches"
    MODEL = WatchList
    MAX_COUNT = MAX_WATCHES
    MAX_BYTES = MAX_WATCH_BYTES
    WHAT = "watch list"
