"""elf_check.py -- is an uploaded binary something irpd can load on this machine?  (pyelftools)

Thread modules: ELF64 x86-64 shared objects (ET_DYN) whose dynamic symbol table defines `run` or
`indurop_module_v1_descriptor`.  Process modules: ELF64 x86-64 executables (ET_EXEC, or ET_DYN
with a PT_INTERP, i.e. a PIE).  Other .so files (libraries a module links to): ELF64 x86-64 ET_DYN.
Each check returns None or a message naming the file and what it is instead.
"""

from __future__ import annotations

from pathlib import Path

from elftools.common.exceptions import ELFError
from elftools.elf.elffile import ELFFile

MODULE_SYMBOLS = ("run", "indurop_module_v1_descriptor")
MACHINES = {"EM_386": "32-bit x86", "EM_AARCH64": "ARM64", "EM_ARM": "32-bit ARM", "EM_RISCV": "RISC-V"}


class NotLoadable(Exception):
    """The file is an ELF of the wrong kind (415) or is no ELF at all."""


class MissingSymbol(Exception):
    """A shared object that is no module: it defines neither `run` nor the descriptor (400)."""


def _open(f, name: str) -> ELFFile:
    if f.read(4) != b"\x7fELF":
        raise NotLoadable(f"{name} is not an ELF file (no \\x7fELF header); upload the built module")
    f.seek(0)
    try:
        elf = ELFFile(f)
    except (ELFError, ValueError, OSError) as e:
        raise NotLoadable(f"{name} is not a valid ELF file: {e}") from e
    if elf.elfclass != 64:
        raise NotLoadable(f"{name} is a 32-bit ELF; irpd runs x86-64 (64-bit) modules")
    if not elf.little_endian:
        raise NotLoadable(f"{name} is a big-endian ELF; irpd runs x86-64 modules")
    machine = elf["e_machine"]
    if machine != "EM_X86_64":
        raise NotLoadable(f"{name} is built for {MACHINES.get(machine, machine)}; irpd runs x86-64 modules")
    return elf


def _defined_dynamic_symbols(elf: ELFFile) -> set[str]:
    tables = [s for s in elf.iter_sections() if s["sh_type"] == "SHT_DYNSYM"]
    if not tables:  # section headers stripped: the dynamic segment still knows its symbols
        tables = [seg for seg in elf.iter_segments() if seg["p_type"] == "PT_DYNAMIC"]
    names = set()
    for table in tables:
        for sym in table.iter_symbols():
            if sym["st_shndx"] != "SHN_UNDEF" and sym["st_info"]["bind"] in ("STB_GLOBAL", "STB_WEAK"):
                names.add(sym.name)
    return names


def _guarded(check):
    """pyelftools raises many kinds of errors on damaged files: each becomes NotLoadable."""

    def run(path: Path, name: str, **kwargs) -> None:
        try:
            check(path, name, **kwargs)
        except (NotLoadable, MissingSymbol):
            raise
        except Exception as e:  # noqa: BLE001 -- any parse failure means "not a loadable ELF"
            raise NotLoadable(f"{name} cannot be read as an ELF file ({type(e).__name__}: {e})") from e

    run.__doc__ = check.__doc__
    return run


@_guarded
def check_shared_object(path: Path, name: str, *, module: str | None) -> None:
    """A .so: a thread module (`module` = its name in module.xml) or a library (module None)."""
    with open(path, "rb") as f:
        elf = _open(f, name)
        if elf["e_type"] != "ET_DYN":
            raise NotLoadable(
                f"{name} is an ELF {elf['e_type']}, not a shared object (ET_DYN); build it with -shared -fPIC"
            )
        if module is not None and not _defined_dynamic_symbols(elf) & set(MODULE_SYMBOLS):
            raise MissingSymbol(
                f"{name} (module '{module}') exports neither run nor indurop_module_v1_descriptor; "
                "a thread module defines extern \"C\" run() or uses INDUROP_MODULE(...)"
            )


@_guarded
def check_executable(path: Path, name: str, *, module: str) -> None:
    """A process module's executable."""
    with open(path, "rb") as f:
        elf = _open(f, name)
        kind = elf["e_type"]
        has_interp = any(seg["p_type"] == "PT_INTERP" for seg in elf.iter_segments())
        if kind == "ET_EXEC" or (kind == "ET_DYN" and has_interp):
            return
        what = "a shared object, not an executable" if kind == "ET_DYN" else f"an ELF {kind}, not an executable"
        raise NotLoadable(
            f"{name} (process module '{module}') is {what}; a process module is a program linked to libindurop"
        )
