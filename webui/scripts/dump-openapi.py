"""dump-openapi.py -- writes the agent's OpenAPI document (the source of the UI's typed client) to
stdout, sorted so that a diff shows only real changes.  `npm run gen-api` regenerates both files."""
import json
import sys
import tempfile
from pathlib import Path

# the agent of this tree, not whichever one the venv installed (a worktree shares main's venv)
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "agent"))

from indurop_agent.api.app import create_app
from indurop_agent.config import Settings

with tempfile.TemporaryDirectory() as data:
    app = create_app(Settings(data_dir=Path(data), irpd_socket=str(Path(data) / "none.sock")), restore=False)
    json.dump(app.openapi(), sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write("\n")
