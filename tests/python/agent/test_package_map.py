"""test_package_map.py -- the agent's package stays a map a newcomer can read (docs/architecture.md
"The agent's folders"): no module imports itself back through others (every `import` and
`from ... import`, relative or absolute, at module level, inside a function or under
TYPE_CHECKING), the package's root keeps only the entry points and what every part shares, and each
process the agent's package makes has one console script, which its `python -m` form, the .deb's
commands and its systemd unit name."""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

from agent_helpers import ROOT

PACKAGE = "indurop_agent"
PACKAGE_DIR = ROOT / "agent" / PACKAGE
PYPROJECT = ROOT / "agent" / "pyproject.toml"
ROOT_MODULES_MAX = 12  # the "a dozen modules at most", __init__.py and __main__.py included


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE_DIR.rglob("*.py"))}


def resolve(node: ast.ImportFrom, current: str, is_package: bool) -> str:
    """The absolute name of the module a `from X import ...` names."""
    if node.level == 0:
        return node.module or ""
    base = current.split(".")
    # a package's own __init__ is at level 1 of itself; a module's level 1 is its package
    base = base if is_package else base[:-1]
    if node.level > 1:
        base = base[: -(node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(path: Path, current: str, known: dict[str, Path]) -> set[str]:
    """The package's modules `current` imports, anywhere in its file."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()

    def add(name: str) -> None:
        # `import a.b.c` runs a.b.c (and its packages, whose __init__ files are leaves here)
        if name in known and name != current:
            found.add(name)

    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            target = resolve(node, current, is_package)
            if not target.startswith(PACKAGE):
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                add(sub if sub in known else target)
    return found


def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: imports(path, name, known) for name, path in known.items()}


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph, as the modules in import order with the first repeated at the end."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_the_finder_names_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_relative_imports_are_resolved():
    edges = graph()
    assert f"{PACKAGE}.config" in edges[f"{PACKAGE}.__main__"]  # `from . import config`


def test_no_module_imports_itself_back():
    cycle = find_cycle(graph())
    assert cycle is None, "an import circle: " + " -> ".join(cycle or [])


def test_the_root_keeps_at_most_a_dozen_modules():
    root = sorted(p.name for p in PACKAGE_DIR.glob("*.py"))
    assert len(root) <= ROOT_MODULES_MAX, (
        f"{len(root)} modules at the root of {PACKAGE} (at most {ROOT_MODULES_MAX}): {', '.join(root)}; "
        "put each in the folder of what it talks to (docs/architecture.md)"
    )


def scripts() -> dict[str, tuple[str, str]]:
    """pyproject's console scripts: name -> (module, function)."""
    table = tomllib.loads(PYPROJECT.read_text())["project"]["scripts"]
    return {name: tuple(target.split(":")) for name, target in table.items()}


def defines(module: str, function: str) -> bool:
    path = modules().get(module)
    tree = ast.parse(path.read_text()) if path else ast.Module(body=[])
    return any(isinstance(n, ast.FunctionDef) and n.name == function for n in tree.body)


def test_each_console_script_is_one_process():
    targets = scripts()
    for name, (module, function) in targets.items():
        assert defines(module, function), f"{PYPROJECT}: {name} = {module}:{function}, which is not there"
    assert len({t for t in targets.values()}) == len(targets), f"two console scripts run the same main: {targets}"


def test_each_python_m_form_is_a_console_script():
    """`python -m indurop_agent[.x]` (demo.sh and the tests start the processes so) is a console
    script itself, or runs the one of its own folder."""
    known = modules()
    targets = {module for module, _ in scripts().values()}
    for name, path in known.items():
        if not name.endswith("__main__") or name in targets:
            continue
        folder = name.rsplit(".", 1)[0]
        runs = [m for m in imports(path, name, known) if m in targets]
        assert len(runs) == 1 and runs[0].startswith(folder + "."), (
            f"{path.relative_to(ROOT)} runs {runs or 'no console script'}: it should run its folder's one"
        )


def test_the_packaged_commands_are_the_console_scripts():
    cmake = (ROOT / "packaging" / "CMakeLists.txt").read_text()
    linked = set(re.search(r"foreach\(_cmd ([^)]*)\)", cmake).group(1).split())
    assert linked == set(scripts()), (
        f"packaging/CMakeLists.txt links {sorted(linked)} into /usr/bin; pyproject has {sorted(scripts())}"
    )
    for unit in sorted((ROOT / "packaging" / "systemd").glob("*.service")):
        for command in re.findall(r"^ExecStart=/usr/bin/(\S+)", unit.read_text(), re.M):
            assert command in scripts(), f"{unit.name} starts /usr/bin/{command}, which is no console script"
