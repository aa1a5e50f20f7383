# sdk.py -- where the module SDK is (headers and libindurop) and how a generated instance is compiled:
# the flags of the project's modules (CMakeLists.txt: C++20, -O2 -g, -Wall -Wextra, PIC, a shared object
# linked to libindurop).  Compile errors of generated C++ are internal errors, placed at the ST line the
# compiler names through #line.

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from .errors import Place, StError

HERE = Path(__file__).resolve().parent
# The flags of CMake's RelWithDebInfo build of a module (CMakeLists.txt, InduropModule.cmake).
CXXFLAGS = ["-std=c++20", "-O2", "-g", "-DNDEBUG", "-fPIC", "-Wall", "-Wextra", "-Wno-unused-parameter"]
LDFLAGS = ["-shared"]


@dataclass
class Kit:
    cxx: str
    includes: list[str]
    libdir: str


def find(prefix: str | None, cxx: str | None) -> Kit:
    """The SDK: --sdk PREFIX (an installed prefix, e.g. /usr, or a build folder of this source tree);
    else the prefix stc is installed in (PREFIX/share/indurop/st/stc_compiler); else this source tree's
    build folder."""
    compiler = cxx or os.environ.get("CXX") or shutil.which("g++") or "c++"
    candidates = [Path(prefix).resolve()] if prefix else [HERE.parents[3], HERE.parents[1] / "build"]
    for root in candidates:
        if (root / "include" / "indurop" / "indurop.h").is_file():
            for lib in ("lib", "lib64", *[str(p.relative_to(root)) for p in (root / "lib").glob("*-linux-gnu")]):
                if (root / lib / "libindurop.so").exists():
                    return Kit(compiler, [str(root / "include")], str(root / lib))
        if (root / "rtcore" / "libindurop.so").exists():  # a build folder: headers from the source tree
            src = HERE.parents[1]
            includes = [str(src / "rtcore" / "include"), str(src / "st" / "runtime" / "include")]
            return Kit(compiler, includes, str(root / "rtcore"))
    where = prefix or " or ".join(str(c) for c in candidates)
    raise StError(
        Place("stc", 1, 1),
        "sdk",
        f"no indurop SDK (include/indurop/indurop.h and libindurop.so) in {where}; give --sdk PREFIX, or --no-compile",
    )


def compile_module(kit: Kit, cpp: str, out: str, name: str) -> list[StError]:
    so = os.path.join(out, f"{name}.so")
    cmd = [kit.cxx, *CXXFLAGS, *[f"-I{d}" for d in kit.includes], f"-I{out}", cpp, *LDFLAGS, "-o", so]
    cmd += [f"-L{kit.libdir}", f"-Wl,-rpath,{kit.libdir}", "-lindurop", "-lpthread"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode == 0:
        return []
    return internal_errors(r.stderr, cpp)


_DIAG = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): (?:fatal )?error: (?P<msg>.*)$", re.M)


def internal_errors(stderr: str, cpp: str) -> list[StError]:
    """The C++ compiler's errors as stc's: at the ST place #line gave them (an error of the compiler)."""
    out = []
    for m in _DIAG.finditer(stderr):
        out.append(
            StError(
                Place(m["file"], int(m["line"]), int(m["col"])),
                "internal",
                f"the C++ generated from this line does not compile ({m['msg']}); this is an error of stc: "
                f"please report it with the ST source ({cpp})",
            )
        )
    if not out:
        text = stderr.strip().splitlines()[-1] if stderr.strip() else "no message"
        out.append(StError(Place(cpp, 1, 1), "internal", f"compiling the generated C++ failed: {text}"))
    return out
