"""python -m indurop_agent.cli: the same as irpctl."""

import sys

from .irpctl import main

sys.exit(main())
