"""system -- the appliance's administration behind the System page (docs/administration.md): the
agent's own restart, irpd's and the agent's logs, backup and restore of the data folder, the TLS
certificate, and the figures GET /system shows."""
