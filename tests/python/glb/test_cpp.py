# test_cpp.py -- the generated header against the C++ compiler: it compiles (so its static_asserts
# prove g++ lays every struct out as layout.json says), the paper's Figure 4 and 5 programs compile
# against Figure 3's header as printed, and every leaf of layout.json is where the header's
# references read and write it.

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from glb_helpers import RTCORE_INCLUDE, arrayref_nesting_works, compile_case, fixture, load_layout, run_glbc

FLAGS = ["-std=c++20", "-Wall", "-Wextra", "-Werror"]


def syntax_check(cxx: str, source: Path, *includes: Path) -> subprocess.CompletedProcess:
    args = [cxx, *FLAGS, "-fsyntax-only", *(f"-I{i}" for i in includes), str(source)]
    return subprocess.run(args, capture_output=True, text=True, timeout=300)


def include_only(folder: Path) -> Path:
    src = folder / "include_only.cpp"
    src.write_text("#include <indurop/generated.h>\nint main() { return 0; }\n")
    return src


@pytest.mark.parametrize("case", ["fig3", "fig11", "fig3_fig11"])
def test_figure_headers_compile(case, cxx, tmp_path):
    out = compile_case(case, tmp_path)
    result = syntax_check(cxx, include_only(tmp_path), out, RTCORE_INCLUDE)
    assert result.returncode == 0, result.stderr


def test_stress_header_compiles(cxx, shared_include, tmp_path):
    out = compile_case("stress", tmp_path)
    result = syntax_check(cxx, include_only(tmp_path), out, shared_include)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("program", ["fig4-output.cpp", "fig5-modify.cpp"])
def test_paper_programs_compile_as_printed(program, cxx, tmp_path):
    out = compile_case("fig3", tmp_path)
    shutil.copyfile(fixture(program), tmp_path / program)
    result = syntax_check(cxx, tmp_path / program, out, RTCORE_INCLUDE)
    assert result.returncode == 0, result.stderr


def test_figure13_style_use_compiles(cxx, tmp_path):
    """What the paper's robot module (Figure 13) does with Figure 11's variables, and the other
    ways a module uses them."""
    out = compile_case("fig3_fig11", tmp_path)
    src = tmp_path / "use.cpp"
    src.write_text("""
#include <indurop/generated.h>
#include <type_traits>
void start() {
    PLC_ROBOT::ROBOT_MODULE_STATE.eState = 3;
    PLC_ROBOT::ROBOT_MODULE_SERVICE.eOpCode = 7;
    for (int k = 0; k < PLC_ROBOT::MAX_JOINTS; k++) PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint[k] = 0.0;
}
void run() {
    int32_t joint[6];
    joint[0] = PLC_ROBOT::AXIS1_IN.position / 1320000 * 360;
    (void)joint;
    knu::Robot::joints[0] = knu::Robot::joints[1];          // a whole struct, consistently
    knu::Robot::joints[2].x = knu::Robot::joints[3].y;
    knu::Robot::joints[4] = knu::Robot::joints_t{1, 2, 3};
    knu::Robot::tick += 10;
    auto a = PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint.load();
    PLC_ROBOT::ROBOT_MODULE_STATE.dCurJoint = a;
    PLC_ROBOT::ROBOT_MODULE_STATE_t s = PLC_ROBOT::ROBOT_MODULE_STATE;
    PLC_ROBOT::ROBOT_MODULE_STATE = s;
    PLC_ROBOT::AXIS1_IN.update([](PLC_ROBOT::AXIS1_IN_t &v) { v.mode = 1; });
    static_assert(std::is_same_v<INDUROP_TYPEDEF(knu::Robot::tick)::value_type, uint32_t>);
    static_assert(std::is_same_v<INDUROP_TYPEDEF(knu::Robot::joints)::value_type, knu::Robot::joints_t>);
    static_assert(std::is_same_v<INDUROP_TYPEDEF(PLC_ROBOT::ROBOT_MODULE_SERVICE.t_speed)::value_type, unsigned long>);
}
""")
    result = syntax_check(cxx, src, out, RTCORE_INCLUDE)
    assert result.returncode == 0, result.stderr


def test_static_asserts_catch_a_wrong_offset(cxx, tmp_path):
    out = compile_case("fig3", tmp_path)
    header = out / "indurop" / "generated.h"
    text = header.read_text()
    assert "offsetof(joints_t, y) == 8 " in text
    header.write_text(text.replace("offsetof(joints_t, y) == 8 ", "offsetof(joints_t, y) == 9 "))
    result = syntax_check(cxx, include_only(tmp_path), out, RTCORE_INCLUDE)
    assert result.returncode != 0 and "glbc layout of joints_t.y" in result.stderr


def test_shared_h_sizes_nested_arrays(cxx, tmp_path):
    assert arrayref_nesting_works(cxx, RTCORE_INCLUDE, tmp_path)


# -- leaves: layout.json against the header's references, at run time ----------------------------


def leaf_program(layout: dict) -> str:
    """A program that writes a distinct value through the reference of every leaf, checks that it
    lands at the leaf's offset, then checks that no later write overwrote it."""
    variables = {v["lock"]: v for v in layout["variables"]}  # with --previous, lock i need not be variable i
    lines = [
        "#include <indurop/generated.h>",
        "#include <cstdio>",
        "#include <cstring>",
        'extern "C" { char *indurop_shared_data; indurop_var_lock *indurop_shared_locks; }',
        "namespace irp::shared {",
        "void lockVariable(uint32_t) noexcept {}",
        "void unlockVariable(uint32_t) noexcept {}",
        "}",
        "static int bad = 0;",
        "template <class Ref, class T>",
        "static void put(const char *path, const Ref &ref, uint64_t offset, T value) {  // by reference:",
        "    // copying a ScalarRef warns under -Wextra (-Wdeprecated-copy)",
        "    if (ref.offset() != offset || sizeof(T) != sizeof(typename Ref::value_type)) {",
        '        std::printf("%s: reference at %llu, layout.json says %llu\\n", path,',
        "                    (unsigned long long)ref.offset(), (unsigned long long)offset);",
        "        ++bad;",
        "    }",
        "    ref = value;",
        "    T raw;",
        "    std::memcpy(&raw, indurop_shared_data + offset, sizeof raw);",
        "    T back = ref;",
        '    if (raw != value || back != value) { std::printf("%s: write did not land\\n", path); ++bad; }',
        "}",
        "template <class T>",
        "static void still(const char *path, uint64_t offset, T value) {",
        "    T raw;",
        "    std::memcpy(&raw, indurop_shared_data + offset, sizeof raw);",
        '    if (raw != value) { std::printf("%s: overwritten by a later leaf\\n", path); ++bad; }',
        "}",
        "int main() {",
        f"    static indurop_var_lock locks[{max(1, layout['lock_count'])}];",
        f"    alignas(64) static char data[{max(64, layout['data_size'])}];",
        "    indurop_shared_data = data;",
        "    indurop_shared_locks = locks;",
    ]
    checks = []
    for k, leaf in enumerate(layout["leaves"]):
        var = variables[leaf["lock"]]
        suffix = leaf["path"][len(var["path"]) :]
        expr = "::" + var["namespace"].replace(".", "::") + "::" + var["name"] + suffix
        value = "true" if leaf["type"] == "bool" else f"({leaf['type']})({k % 120 + 1})"
        typ = "bool" if leaf["type"] == "bool" else leaf["type"]
        lines.append(f'    put("{leaf["path"]}", {expr}, {leaf["offset"]}u, {value});')
        checks.append(f'    still<{typ}>("{leaf["path"]}", {leaf["offset"]}u, {value});')
    lines += checks
    lines += ['    if (bad == 0) std::printf("ok\\n");', "    return bad != 0;", "}"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("case", ["fig3", "fig11", "stress"])
def test_leaves_are_where_the_references_point(case, cxx, shared_include, tmp_path):
    out = compile_case(case, tmp_path)
    src = tmp_path / "leaves.cpp"
    src.write_text(leaf_program(load_layout(out)))
    exe = tmp_path / "leaves"
    include = RTCORE_INCLUDE if case != "stress" else shared_include
    build = subprocess.run(
        [cxx, *FLAGS, "-O0", f"-I{out}", f"-I{include}", str(src), "-o", str(exe)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and run.stdout == "ok\n", run.stdout + run.stderr


def test_leaves_of_a_layout_laid_out_against_a_previous_one(cxx, tmp_path):
    """glbc --previous: kept, moved and new variables out of declaration order, locks with gaps."""
    out = compile_case("fig3_fig11", tmp_path)
    (tmp_path / "b.glb").write_text(
        "namespace knu.Robot;\nstruct { double x; double y; } joints[10]\nint added[3];\nuint32_t tick;\n"
    )
    result = run_glbc(["fig11-plcRobot.glb", "b.glb", "-o", "next", "--previous", str(out / "layout.json")], tmp_path)
    assert result.returncode == 0, result.stderr
    layout = load_layout(tmp_path / "next")
    assert layout["changes"]["converted"] and layout["changes"]["added"] and layout["changes"]["removed"] == []
    src = tmp_path / "leaves.cpp"
    src.write_text(leaf_program(layout))
    build = subprocess.run(
        [cxx, *FLAGS, "-O0", f"-I{tmp_path / 'next'}", f"-I{RTCORE_INCLUDE}", str(src), "-o", str(tmp_path / "leaves")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / "leaves")], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and run.stdout == "ok\n", run.stdout + run.stderr


def compile_glb_text(cxx, glb, files: dict[str, str], include: Path = RTCORE_INCLUDE):
    result = glb(files)
    assert result.returncode == 0, result.stderr
    return syntax_check(cxx, include_only(glb.folder), glb.out, include)


def test_header_of_empty_input_compiles(cxx, glb):
    result = compile_glb_text(cxx, glb, {"empty.glb": "// nothing yet\n"})
    assert result.returncode == 0, result.stderr


def test_header_of_several_files_and_namespaces_compiles(cxx, glb):
    result = compile_glb_text(
        cxx,
        glb,
        {
            "a.glb": "namespace a;\n#define N 2\nint x[N];\n",
            "ab.glb": "namespace a.b;\nstruct { double v; } s;\n",
            "a2.glb": "namespace a;\nstruct { char c[N]; } t;\n",
        },
    )
    assert result.returncode == 0, result.stderr


def test_fields_named_like_reference_members_compile(cxx, glb):
    """Field and variable names that the reference classes also use (constructor parameters,
    RefBase and ArrayRef members) are fine."""
    result = compile_glb_text(
        cxx,
        glb,
        {
            "a.glb": (
                "namespace a;\n"
                "struct { int offset; int lock; int size; int at; int extent; int reference; int array_type;\n"
                "         int address; int lockIndex; int in_aggregate; struct { int offset; } lock_t; } offset;\n"
                "int lock;\n"
            )
        },
    )
    assert result.returncode == 0, result.stderr
