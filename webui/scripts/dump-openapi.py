"""dump-openapi.py -- writes the agent's OpenAPI document (the source of the UI's typed client) to
stdout, sorted so that a diff shows only real changes.  `npm run gen-api` regenerates both files."""
import json
import sys
import tempfile
from pathlib import Path

from indurop_agent.app import create_app
from indurop_agent.config import Settings

with tempfile.TemporaryDirectory() as data:
    app = create_app(Settings(data_dir=Path(data), irpd_socket=str(Path(data) / "none.sock")), restore=False)
    json.dump(app.openapi(), sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")
