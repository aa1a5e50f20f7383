"""access -- who may do what, and the record of it (docs/security.md): the people who sign in
(users.py) and their browser sessions (sessions.py), bearer tokens and roles (auth.py), the audit
log (audit.py) and its lines of refused requests (refusals.py), and the guards that are not about
roles: the brute-force lockout and the request bodies' limits (security.py).  The OPC UA server
signs its users in and audits with these too."""
