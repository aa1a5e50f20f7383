"""capture_limits.py -- every limit of the triggered captures in one place: the API's models
(capture_models.py, hence OpenAPI and the web UI's schema), the engine's checks and
docs/recorder.md take them from here; GET /api/v1/captures/limits answers them with the running
ring's capacity."""

from __future__ import annotations

from ..irpd.trace import LAYOUT as TRACE_LAYOUT

MiB = 1 << 20

# Channels of one capture, the trigger's variables included: what irpd traces at most (the trace
# segment's description, docs/trace-and-stream.md), for every owner together.
MAX_CHANNELS = TRACE_LAYOUT.constant("channels")
# Conditions one trigger combines with AND or OR.
MAX_CONDITIONS = 4
# Pre-trigger rows: at most what the trace rings hold (their capacity, read from the running
# irpd: 16 384 rows by default, 1.6 s at 100 µs); this is that default, for the docs.
DEFAULT_RING_ROWS = 16384
# Post-trigger rows (the trigger row not counted); the memory bound below usually comes first.
MAX_POST_ROWS = 1_000_000
# What a length may say at all (the limits above are checked once it is in rows).
MAX_LENGTH_ROWS = 1_000_000_000
MAX_LENGTH_S = 1_000_000.0
# Rows a level or window condition must hold before it triggers.
MAX_HOLD_ROWS = 1_000_000
# Memory of one armed capture: its history (pre-trigger rows, plus the rows an event may come late
# by, plus one block) and one shot (pre + 1 + post rows), 8 bytes per value and per due time.
MAX_CAPTURE_BYTES = 64 * MiB
# Memory of every armed capture together.
MAX_TOTAL_BYTES = 256 * MiB
# Captures armed at once (each traced as the owner "capture"; their variables share the 64 channels).
MAX_ARMED = 8
# Captures listed (armed, idle or done); arm more and the oldest idle or done one must be deleted first.
MAX_CAPTURES = 64
# Shots (one per trigger) kept per capture: a repeated capture keeps its newest ones.
MAX_SHOTS_KEPT = 50
# A repeated capture's count of shots (0: until disarmed).
MAX_REPEAT = 100_000
# How late (seconds after its time) an alarm, fault, swap or manual trigger may reach the engine and
# still find its pre-trigger rows: the engine holds this much more history for such triggers.  The
# agent reads irpd's events every second (irpd_poll_s) and the alarm segment every 0.1 s.
EVENT_LAG_S = 2.5
# Rows the engine processes in one step (it reads what is new every POLL_S).
BLOCK_ROWS = 1024
POLL_S = 0.02
# A triggered capture whose rows stopped coming (irpd stopped sampling, or restarted) for this
# long is saved with the post-trigger rows it has.
STALL_S = 2.0
# A capture's name.
MAX_NAME_CHARS = 64
# The trace owner the captures' channels are asked for as (irpd's `trace` with `owner`).
TRACE_OWNER = "capture"


def as_dict(ring_rows: int | None = None) -> dict:
    """The limits as GET /captures/limits answers them (ring_rows: the running ring's capacity)."""
    return {
        "max_channels": MAX_CHANNELS,
        "max_conditions": MAX_CONDITIONS,
        "max_pre_rows": ring_rows or DEFAULT_RING_ROWS,
        "ring_rows": ring_rows,
        "max_post_rows": MAX_POST_ROWS,
        "max_hold_rows": MAX_HOLD_ROWS,
        "max_capture_bytes": MAX_CAPTURE_BYTES,
        "max_total_bytes": MAX_TOTAL_BYTES,
        "max_armed": MAX_ARMED,
        "max_captures": MAX_CAPTURES,
        "max_shots_kept": MAX_SHOTS_KEPT,
        "max_repeat": MAX_REPEAT,
        "event_lag_s": EVENT_LAG_S,
        "max_name_chars": MAX_NAME_CHARS,
    }
