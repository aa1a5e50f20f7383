"""python -m indurop_agent.opcua: the same as indurop-opcua."""

import sys

from .server import main

sys.exit(main())
