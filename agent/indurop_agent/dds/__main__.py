"""python -m indurop_agent.dds: the same as indurop-dds-bridge."""

import sys

from .bridge import main

sys.exit(main())
