"""cli -- irpctl, the command line of the agent's API (docs/irpctl.md), and the Python client it
calls the API with: irpctl.py is the command table and its entry, base.py and text.py what the
command groups share (exit codes, arguments, how they print), one module per group (alarms.py,
capture.py, line.py, opcua.py, record.py, scope.py, system.py, users.py); client.py is the client
(with client_system.py and client_record.py mixed in, and client_errors.py its ApiError)."""
