"""test_editor_language.py -- the web UI's editor knows Structured Text from the compiler's truths
only: webui/src/programs/st_language.ts is generated from st/st.lark, stdlib.py, types.py and st/lib
by st/generate_editor.py, and fails here when stale, naming the command that regenerates it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
_spec = importlib.util.spec_from_file_location("st_generate_editor", ROOT / "st" / "generate_editor.py")
generate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(generate)


def test_the_generated_file_is_fresh():
    for path, text in generate.outputs().items():
        assert path.read_text() == text, f"{path.relative_to(ROOT)} is stale: run `{generate.COMMAND}`"


def test_a_new_standard_function_makes_it_stale_until_regenerated(monkeypatch, capsys):
    """A row added to stdlib.py's table: --check fails naming the file and the command."""
    from generated_files import write_or_check

    monkeypatch.setitem(
        generate.stdlib.FUNCTIONS,
        "NEWFN",
        generate.stdlib.Function("NEWFN", (generate.stdlib.Param("IN", "INT"),), "INT"),
    )
    outputs = generate.outputs()
    assert '"NEWFN"' in outputs[generate.TYPESCRIPT]
    assert write_or_check(outputs, True, generate.COMMAND, ROOT) == 1
    assert "webui/src/programs/st_language.ts is stale: run `python3 st/generate_editor.py`" in capsys.readouterr().err


def test_it_holds_what_the_editor_needs():
    text = generate.TYPESCRIPT.read_text()
    for keyword in ("FUNCTION_BLOCK", "END_FUNCTION_BLOCK", "IF", "END_IF", "ELSIF", "VAR_INPUT", "CASE"):
        assert f'"{keyword}"' in text, keyword
    # a standard function with its parameters, a library FB with its inputs and outputs
    assert '{"name": "LIMIT", "kind": "function", "result": "T", "params": [{"name": "MN"' in text
    assert '{"name": "TON", "kind": "FUNCTION_BLOCK"' in text
    assert '{"name": "PT", "kind": "VAR_INPUT", "type": "TIME"}' in text
    assert '"MC_MoveAbsolute"' in text
