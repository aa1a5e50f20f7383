"""The OPC UA server (docs/opcua.md): the controller's shared variables, module figures and alarms
for SCADA, MES and HMIs, on asyncua.

server.py is the process (`indurop-opcua`; `python -m indurop_agent.opcua` is the same), settings.py
its settings and limits, values.py the layout's types and tree and the reads of the variable
segment, address_space.py the nodes, sampling.py what feeds monitored items (the trace rings, the
segment), subscriptions.py asyncua's subscription service with the spec's revisions, queues and
bounds, writes.py writes through irpd with their audit lines, security.py users, roles, the
certificate and the trust list's check, pki.py the PKI folders' certificates and the moves between
them (the agent's GET /opcua and trust routes use it too), alarms.py the alarm segment's records as
events.
"""
