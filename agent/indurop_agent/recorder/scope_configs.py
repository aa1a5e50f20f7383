"""scope_configs.py -- trace configurations kept beside a stored set (docs/recorder.md "Trace
configurations"): <data>/sets/<id>/scopes/<name>.json, each a capture request (the model POST
/captures takes) and what the Scope page needs to show it again.  Stored as every file kept with a
set is (sets/kept.py)."""

from __future__ import annotations

from ..api.scope_models import MAX_CONFIG_BYTES, MAX_CONFIGS, ScopeConfig
from ..sets.kept import Kept, KeptError

ScopeError = KeptError


class ScopeConfigs(Kept):
    FOLDER = "scopes"
    MODEL = ScopeConfig
    MAX_COUNT = MAX_CONFIGS
    MAX_BYTES = MAX_CONFIG_BYTES
    WHAT = "trace configuration"


parse = ScopeConfigs.parse
