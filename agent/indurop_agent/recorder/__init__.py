"""recorder -- the scope and recorder (docs/recorder.md): triggered captures of the trace rings' rows."""
