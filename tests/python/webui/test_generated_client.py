"""test_generated_client.py -- the UI's typed client is generated from the agent's OpenAPI
document; these fail when webui/openapi.json or webui/src/api/schema.d.ts is stale, and name the
command that regenerates both."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
WEBUI = ROOT / "webui"
REGENERATE = "cd webui && npm run gen-api"


def test_openapi_json_matches_the_agent():
    now = subprocess.run([sys.executable, str(WEBUI / "scripts" / "dump-openapi.py")], check=True,
                         capture_output=True, text=True, cwd=ROOT / "agent").stdout
    assert now == (WEBUI / "openapi.json").read_text(), f"webui/openapi.json is stale: run `{REGENERATE}`"


def test_schema_types_match_openapi_json(tmp_path):
    tool = WEBUI / "node_modules" / ".bin" / "openapi-typescript"
    if not tool.exists():
        pytest.fail("webui/node_modules is missing: run `bash packaging/build.sh` (it runs npm ci)")
    out = tmp_path / "schema.d.ts"
    subprocess.run([str(tool), "openapi.json", "-o", str(out)], check=True, capture_output=True, cwd=WEBUI)
    assert out.read_text() == (WEBUI / "src" / "api" / "schema.d.ts").read_text(), \
        f"webui/src/api/schema.d.ts is stale: run `{REGENERATE}`"
