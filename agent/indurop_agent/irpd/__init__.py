"""irpd -- everything that speaks to irpd or reads its shared memory (docs/control-protocol.md,
docs/shared-memory.md): the control socket's client (client.py) and the protocol generated from
protocol/control.json (protocol.py), the segments' layouts as irpd describes them (shm_layout.py,
shm_layout.json from `ninja -C build shm-layout`), the shared variables (variables.py) and the trace
rings (trace.py)."""
