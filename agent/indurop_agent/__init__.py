"""indurop-agent: the non-real-time agent beside irpd (REST API under /api/v1)."""

__version__ = "0.1.0"
