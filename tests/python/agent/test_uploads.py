"""test_uploads.py -- every way POST /sets refuses an upload, one named test (or case) per malformed
input: the exact status, a detail naming the problem, and nothing left in the store (blobs, sets,
uploads in progress).  Names are sent byte by byte (agent_helpers.multipart), archives are built
with tarfile, ELF files are real ones from gcc, patched where a test needs a wrong one.
irpd is absent here: these refusals happen before the agent asks it anything."""

from __future__ import annotations

import gzip
import os
import tarfile

import pytest
from agent_helpers import files_body, module_xml, multipart, patched, post_set, small_set, tar_gz, wrong_machine
from indurop_agent.sets.uploads import UploadError, clean_name

GZ = "application/gzip"


def refused(agent, response, status: int, *words: str) -> str:
    """Asserts the refusal and that nothing was stored; returns the detail."""
    assert response.status_code == status, response.text
    detail = response.json()["detail"]
    for w in words:
        assert w in detail, (w, detail)
    assert agent.stored() == [], "a refused upload left files behind"
    return detail


# ---- names --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "name, normalized",
    [
        ("module.xml", "module.xml"),
        ("./module.xml", "module.xml"),
        ("lib//a.so", "lib/a.so"),
        ("lib/./a.so", "lib/a.so"),
        ("meshes/arm link.stl", "meshes/arm link.stl"),
        ("ünïcode.txt", "ünïcode.txt"),
        ("50%.txt", "50%.txt"),
        ("{0}%s.txt", "{0}%s.txt"),
    ],
)
def test_good_names_are_normalized(name, normalized):
    assert clean_name(name) == normalized


BAD_NAMES = {
    "empty": ("", "empty"),
    "dot only": ("./", "names no file"),
    "parent": ("../evil.txt", "'..'"),
    "parent inside": ("lib/../../evil.txt", "'..'"),
    "absolute": ("/etc/passwd", "absolute"),
    "nul": ("a\0b.txt", "NUL"),
    "newline": ("a\nb.txt", "control character"),
    "backslash": ("..\\evil.txt", "backslash"),
    "percent dot dot": ("%2e%2e/evil.txt", "percent-escape"),
    "percent dot dot upper": ("%2E%2E/evil.txt", "percent-escape"),
    "percent slash": ("..%2fevil.txt", "percent-escape"),
    "percent backslash": ("..%5cevil.txt", "percent-escape"),
    "double encoded": ("%252e%252e/evil.txt", "percent-escape"),
    "too long": ("a" * 252 + ".txt", "the limit is 255"),
    "too long in utf-8": ("é" * 127 + ".txt", "the limit is 255"),
    "lone surrogate": ("a\udcff.txt", "UTF-8"),
}


@pytest.mark.parametrize("case", list(BAD_NAMES))
def test_bad_names_are_refused_with_400(case):
    name, words = BAD_NAMES[case]
    with pytest.raises(UploadError) as e:
        clean_name(name)
    assert e.value.status_code == 400 and words in e.value.detail


@pytest.mark.parametrize("case", [c for c in BAD_NAMES if c not in ("lone surrogate",)])
def test_bad_names_in_multipart_parts_store_nothing(agent, elves, case):
    name, words = BAD_NAMES[case]
    body, ctype = multipart([("files", n, c) for n, c in small_set(elves).items()] + [("files", name, b"x")])
    if case == "backslash":
        words = "backslash"
    refused(agent, post_set(agent, body, ctype), 400, words)


def test_a_filename_that_is_not_utf8_is_refused(agent, elves):
    body, ctype = multipart([("files", n, c) for n, c in small_set(elves).items()] + [("files", b"\xff\xfe.txt", b"x")])
    refused(agent, post_set(agent, body, ctype), 400, "not valid UTF-8")


def test_a_file_twice_is_refused(agent, elves):
    body, ctype = multipart([("files", n, c) for n, c in small_set(elves).items()] + [("files", "./README.md", b"x")])
    refused(agent, post_set(agent, body, ctype), 400, '"README.md" is in the upload twice')


def test_a_name_that_is_file_and_folder_is_refused(agent, elves):
    r = post_set(agent, *files_body({**small_set(elves), "lib": b"x"}))
    refused(agent, r, 400, '"lib" is both a file and a folder')


def test_a_part_without_a_filename_or_an_unknown_field_is_refused(agent, elves):
    body, ctype = multipart([("files", None, b"x")])
    refused(agent, post_set(agent, body, ctype), 400, "without a filename")
    body, ctype = multipart([("config", "module.xml", b"x")])
    refused(agent, post_set(agent, body, ctype), 400, 'unknown form field "config"')


def test_files_and_an_archive_together_are_refused(agent, elves):
    body, ctype = multipart([("files", "module.xml", b"<root/>"), ("archive", "set.tar.gz", tar_gz([]))])
    refused(agent, post_set(agent, body, ctype), 400, "not both")


def test_a_truncated_multipart_body_is_refused(agent, elves):
    body, ctype = files_body(small_set(elves))
    refused(agent, post_set(agent, body[:-40], ctype), 400)


def test_a_body_of_another_type_is_refused_with_415(agent):
    refused(agent, post_set(agent, b'{"files": []}', "application/json"), 415, "multipart/form-data")


def test_an_empty_upload_is_refused(agent):
    body, ctype = multipart([])
    refused(agent, post_set(agent, body, ctype), 400, "no files")


# ---- archives -----------------------------------------------------------------------------------
def member(name: str, kind: bytes, linkname: str = "") -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = kind, linkname
    return info


@pytest.mark.parametrize(
    "case, entry, words",
    [
        ("symlink", member("evil", tarfile.SYMTYPE, "/etc/passwd"), "symbolic link"),
        ("symlink inside", member("lib/alias.so", tarfile.SYMTYPE, "ctl.so"), "symbolic link"),
        ("hard link", member("evil", tarfile.LNKTYPE, "module.xml"), "hard link"),
        ("char device", member("dev/null", tarfile.CHRTYPE), "device file"),
        ("block device", member("dev/sda", tarfile.BLKTYPE), "device file"),
        ("fifo", member("pipe", tarfile.FIFOTYPE), "FIFO"),
        ("traversal", ("../evil.txt", b"x"), "'..'"),
        ("traversal deep", ("lib/../../../evil.txt", b"x"), "'..'"),
        ("absolute", ("/etc/cron.d/evil", b"x"), "absolute"),
        ("percent-encoded traversal", ("%2e%2e/%2e%2e/evil.txt", b"x"), "percent-escape"),
        ("backslash", ("..\\..\\evil.txt", b"x"), "backslash"),
        ("control character", ("evil\x1b[2J.txt", b"x"), "control character"),
    ],
)
def test_archives_with_links_devices_or_bad_names_are_refused(agent, elves, case, entry, words):
    archive = tar_gz([*small_set(elves).items(), entry])
    refused(agent, post_set(agent, archive, GZ), 400, words)
    body, ctype = multipart([("archive", "set.tar.gz", archive)])
    refused(agent, post_set(agent, body, ctype), 400, words)


def test_a_huge_pax_header_is_refused_before_it_is_read(agent, elves):
    archive = tar_gz(list(small_set(elves).items()), format=tarfile.PAX_FORMAT, pax_headers={"comment": "x" * 200_000})
    refused(agent, post_set(agent, archive, GZ), 400, "extended header")


def test_a_body_that_is_not_gzip_is_refused(agent):
    refused(agent, post_set(agent, b"this is no archive", GZ), 400, "not a readable .tar.gz")


def test_a_gzip_that_is_not_tar_is_refused(agent):
    refused(agent, post_set(agent, gzip.compress(b"hello " * 1000), GZ), 400, "not a readable .tar.gz")


def test_an_archive_of_one_folder_takes_that_folder_as_the_root(agent, elves):
    archive = tar_gz([(f"myset/{n}", c) for n, c in small_set(elves).items()])
    r = post_set(agent, archive, GZ)
    assert r.status_code == 201, r.text
    assert {f["path"] for f in r.json()["files"]} == set(small_set(elves))


# ---- limits -------------------------------------------------------------------------------------
def test_a_file_over_the_limit_is_refused_with_413_while_streaming(make_agent, elves):
    agent = make_agent(max_file_bytes=64 * 1024, max_upload_bytes=1 << 20)
    files = {**small_set(elves), "big.txt": b"x" * (64 * 1024 + 1)}
    refused(agent, post_set(agent, *files_body(files)), 413, '"big.txt" is larger than 65536 bytes')


def test_an_archive_member_over_the_limit_is_refused_by_its_header(make_agent, elves):
    agent = make_agent(max_file_bytes=64 * 1024, max_upload_bytes=1 << 20)
    archive = tar_gz([*small_set(elves).items(), ("zeros.txt", bytes(10 << 20))])  # 10 MiB of zeros: ~10 kB gzipped
    assert len(archive) < 64 * 1024
    refused(agent, post_set(agent, archive, GZ), 413, '"zeros.txt" is', "limit per file is 65536")


def test_an_archive_that_unpacks_past_the_upload_limit_is_refused(make_agent, elves):
    agent = make_agent(max_file_bytes=100_000, max_upload_bytes=200_000)
    archive = tar_gz([*small_set(elves).items()] + [(f"pad{i}.txt", bytes(90_000)) for i in range(4)])
    refused(agent, post_set(agent, archive, GZ), 413, "larger than 200000 bytes")


def test_an_archive_and_its_content_each_have_the_upload_limit(make_agent, elves):
    """The compressed archive and what it unpacks to are limited separately, not added up."""
    files = small_set(elves)
    size = sum(len(c) for c in files.values())
    noise = os.urandom(size)  # does not compress: the archive is about as large as its content
    agent = make_agent(max_file_bytes=4 * size, max_upload_bytes=int(3.5 * size))
    r = post_set(agent, tar_gz([*files.items(), ("noise.txt", noise)]), GZ)
    assert r.status_code == 201, r.text  # archive ~2*size, content 2*size: each under 3.5*size, not their sum


def test_more_files_than_the_limit_are_refused(make_agent, elves):
    agent = make_agent(max_files=5)
    files = {**small_set(elves), "one.txt": b"1"}
    refused(agent, post_set(agent, *files_body(files)), 413, "more than 5 files")
    refused(agent, post_set(agent, tar_gz(list(files.items())), GZ), 413, "more than 5 files")


def test_a_declared_content_length_over_the_limit_is_refused_before_reading(make_agent, elves):
    agent = make_agent(max_file_bytes=1000, max_upload_bytes=1000)
    r = agent.client.post(
        "/api/v1/sets", content=b"x" * 200_000, headers={**agent.h(), "Content-Type": GZ, "Content-Length": "200000"}
    )
    refused(agent, r, 413, "the limit is 1000")


def test_a_streamed_body_without_length_is_cut_at_the_limit(make_agent):
    agent = make_agent(max_file_bytes=1000, max_upload_bytes=1000)

    def chunks():
        for _ in range(100):
            yield b"\0" * 1000

    r = agent.client.post("/api/v1/sets", content=chunks(), headers={**agent.h(), "Content-Type": GZ})
    refused(agent, r, 413, "larger than 1000 bytes")


# ---- module.xml ---------------------------------------------------------------------------------
def test_no_module_xml_is_refused(agent, elves):
    files = small_set(elves)
    del files["module.xml"]
    refused(agent, post_set(agent, *files_body(files)), 400, "no module.xml at the root")


def test_a_module_xml_in_a_folder_is_refused_with_a_hint(agent, elves):
    files = {f"sub/{n}": c for n, c in small_set(elves).items()}
    refused(agent, post_set(agent, *files_body(files)), 400, "no module.xml at the root", '"sub/module.xml"')


def test_a_second_module_xml_is_refused(agent, elves):
    files = {**small_set(elves), "old/module.xml": module_xml()}
    refused(agent, post_set(agent, *files_body(files)), 400, '"old/module.xml": a set has one module.xml')


def test_a_missing_module_file_is_refused_naming_the_file_and_the_module(agent, elves):
    files = small_set(elves)
    del files["lib/ctl.so"]
    refused(agent, post_set(agent, *files_body(files)), 400, 'module "ctl"', '"./lib/ctl.so"', "not in the upload")


def test_a_missing_layout_is_refused(agent, elves):
    xml = module_xml(("./lib/ctl.so", "thread"), extra="<layout>vars.json</layout>\n")
    files = {**small_set(elves), "module.xml": xml}
    refused(agent, post_set(agent, *files_body(files)), 400, '<layout> names "vars.json"')


@pytest.mark.parametrize(
    "filename, words", [("/opt/ctl.so", "absolute"), ("../ctl.so", "'..'"), ("%2e%2e/ctl.so", "percent-escape")]
)
def test_a_module_file_outside_the_set_is_refused(agent, elves, filename, words):
    files = {**small_set(elves), "module.xml": module_xml((filename, "thread"))}
    refused(agent, post_set(agent, *files_body(files)), 400, "<filename>", words)


BILLION_LAUGHS = b"""<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
]>
<root><module><filename>&lol4;</filename></module></root>
"""
XXE = b"""<?xml version="1.0"?>
<!DOCTYPE root [<!ENTITY secret SYSTEM "file:///etc/shadow">]>
<root><module><filename>&secret;</filename></module></root>
"""
DTD_ONLY = b"""<?xml version="1.0"?>
<!DOCTYPE root SYSTEM "http://example.invalid/root.dtd">
<root/>
"""


@pytest.mark.parametrize(
    "case, text", [("billion laughs", BILLION_LAUGHS), ("external entity", XXE), ("external DTD", DTD_ONLY)]
)
def test_xml_bombs_and_dtds_in_module_xml_are_refused(agent, elves, case, text):
    files = {**small_set(elves), "module.xml": text}
    refused(agent, post_set(agent, *files_body(files)), 400, "module.xml", "DTD")


def test_an_xml_bomb_in_another_config_is_refused_naming_it(agent, elves):
    files = {**small_set(elves), "ioconfig.xml": BILLION_LAUGHS}
    refused(agent, post_set(agent, *files_body(files)), 400, '"ioconfig.xml"', "DTD")


def test_malformed_module_xml_is_refused_with_its_line(agent, elves):
    files = {**small_set(elves), "module.xml": b"<root>\n<module>\n</root>\n"}
    refused(agent, post_set(agent, *files_body(files)), 400, "module.xml: malformed XML", "line 3")


def test_malformed_json_is_refused(agent, elves):
    files = {**small_set(elves), "layout.json": b'{"leaves": ['}
    refused(agent, post_set(agent, *files_body(files)), 400, '"layout.json" is not valid JSON')


# ---- where: file, line and column beside the detail ---------------------------------------------
def located(response, status: int, file: str, line: int | None = None, column: int | None = None) -> dict:
    """Asserts the refusal's status and where it points; returns the body."""
    assert response.status_code == status, response.text
    body = response.json()
    assert body.get("file") == file, body
    assert body.get("line") == line, body
    if column is not None:
        assert body.get("column") == column, body
    return body


def test_malformed_module_xml_says_the_file_line_and_column(agent, elves):
    files = {**small_set(elves), "module.xml": b"<root>\n<module>\n</root>\n"}
    body = located(post_set(agent, *files_body(files)), 400, "module.xml", 3, 3)  # expat: "line 3, column 2"
    assert body["detail"] == "module.xml: malformed XML: mismatched tag: line 3, column 2"


def test_a_module_naming_a_missing_file_points_at_its_filename_line(agent, elves):
    files = small_set(elves)
    del files["lib/ctl.so"]
    body = located(post_set(agent, *files_body(files)), 400, "module.xml", 4, 5)  # <filename> of the first module
    assert body["detail"].startswith('module.xml: module "ctl" names "./lib/ctl.so"')


def test_an_absolute_module_file_points_at_its_filename_line(agent, elves):
    files = {**small_set(elves), "module.xml": module_xml(("./proc.exe", "process"), ("/opt/ctl.so", "thread"))}
    located(post_set(agent, *files_body(files)), 400, "module.xml", 11, 5)  # the second <filename>


def test_a_missing_layout_points_at_its_line(agent, elves):
    xml = module_xml(("./lib/ctl.so", "thread"), extra="<layout>vars.json</layout>\n")
    line = xml.decode().splitlines().index("<layout>vars.json</layout>") + 1
    located(post_set(agent, *files_body({**small_set(elves), "module.xml": xml})), 400, "module.xml", line, 1)


def test_malformed_json_says_the_file_line_and_column(agent, elves):
    files = {**small_set(elves), "layout.json": b'{\n  "leaves": [,]\n}'}
    body = located(post_set(agent, *files_body(files)), 400, "layout.json", 2, 14)
    assert body["detail"].startswith('"layout.json" is not valid JSON: Expecting value: line 2 column 14')


def test_a_malformed_config_names_itself(agent, elves):
    files = {**small_set(elves), "cfg/io.xml": b"<io>\n<a></b>\n</io>\n"}
    located(post_set(agent, *files_body(files)), 400, "cfg/io.xml", 2, 6)


def test_file_refusals_name_the_file_without_a_line(agent, elves):
    located(post_set(agent, *files_body({**small_set(elves), "lib/ctl.so": b"not an elf"})), 415, "lib/ctl.so")
    located(post_set(agent, *files_body({**small_set(elves), "install.sh": b"#!/bin/sh\n"})), 415, "install.sh")
    located(post_set(agent, *files_body({**small_set(elves), "ioconfig.xml": BILLION_LAUGHS})), 400, "ioconfig.xml")


def test_refusals_that_are_about_no_file_carry_only_the_detail(agent):
    r = agent.client.post("/api/v1/sets", content=b"x", headers={**agent.h(), "Content-Type": "text/plain"})
    assert r.status_code == 415 and set(r.json()) == {"detail"}


# ---- kinds and ELF checks -----------------------------------------------------------------------
@pytest.mark.parametrize("name", ["install.sh", "payload.py", "lib/libfoo.so.1", "Makefile", "set.tar.gz"])
def test_files_of_other_kinds_are_refused_with_415_naming_them(agent, elves, name):
    files = {**small_set(elves), name: b"#!/bin/sh\nrm -rf /\n"}
    refused(agent, post_set(agent, *files_body(files)), 415, f'"{name}"', "does not hold files of this kind")


def test_a_so_that_is_not_an_elf_is_refused_with_415(agent, elves):
    files = {**small_set(elves), "lib/ctl.so": b"#!/bin/sh\necho not a module\n"}
    refused(agent, post_set(agent, *files_body(files)), 415, '"lib/ctl.so" is not an ELF file')


def test_a_truncated_elf_is_refused_with_415(agent, elves):
    files = {**small_set(elves), "lib/ctl.so": elves.module[:100]}
    refused(agent, post_set(agent, *files_body(files)), 415, '"lib/ctl.so"')


@pytest.mark.parametrize("machine, words", [(3, "32-bit x86"), (183, "ARM64"), (40, "EM_ARM")])
def test_a_so_for_another_architecture_is_refused_with_415(agent, elves, machine, words):
    files = {**small_set(elves), "lib/ctl.so": wrong_machine(elves.module, machine)}
    refused(agent, post_set(agent, *files_body(files)), 415, '"lib/ctl.so"', "x86-64")


def test_a_32_bit_elf_is_refused_with_415(agent, elves):
    files = {**small_set(elves), "lib/ctl.so": patched(elves.module, 4, b"\x01")}  # EI_CLASS = ELFCLASS32
    refused(agent, post_set(agent, *files_body(files)), 415, '"lib/ctl.so"')


def test_a_thread_module_that_exports_no_run_is_refused_with_400(agent, elves):
    files = {**small_set(elves), "lib/ctl.so": elves.library}
    refused(agent, post_set(agent, *files_body(files)), 400, '"lib/ctl.so" (module \'ctl\') exports neither run')


def test_a_thread_module_that_is_an_executable_is_refused(agent, elves):
    files = {**small_set(elves), "lib/ctl.so": elves.exec_}
    refused(agent, post_set(agent, *files_body(files)), 415, "not a shared object")


def test_a_process_module_that_is_a_shared_object_is_refused(agent, elves):
    files = {**small_set(elves), "proc.exe": elves.library}
    refused(
        agent, post_set(agent, *files_body(files)), 415, '"proc.exe" (process module \'proc\')', "not an executable"
    )


def test_a_process_module_that_is_no_elf_is_refused(agent, elves):
    files = {**small_set(elves), "proc.exe": b"#!/bin/sh\nexec evil\n"}
    refused(agent, post_set(agent, *files_body(files)), 415, '"proc.exe" is not an ELF file')


def test_accepted_kinds(agent, elves):
    """Every kind a set may hold, each judged by content where it matters."""
    files = {
        "module.xml": module_xml(
            ("./lib/ctl.so", "thread"), ("./descr.so", "thread"), ("./proc.exe", "process"), ("./bin/static", "process")
        ),
        "lib/ctl.so": elves.module,
        "descr.so": elves.descriptor,
        "proc.exe": elves.pie,
        "bin/static": elves.exec_,
        "lib/libhelper.so": elves.library,
        "ioconfig.xml": b"<io/>",
        "layout.json": b"{}",
        "robot.urdf": b"<robot/>",
        "vars.glb": b"joint { double x; }",
        "meshes/arm.glb": b"glTF\x02\x00\x00\x00",
        "meshes/a.stl": b"solid a",
        "meshes/b.dae": b"<COLLADA/>",
        "meshes/c.obj": b"v 0 0 0",
        "view.json": b"[]",
        "indurop/generated.h": b"#pragma once\n",
        "notes.txt": b"hi",
        "README.md": b"# hi",
    }
    r = post_set(agent, *files_body(files))
    assert r.status_code == 201, r.text
    kinds = {f["path"]: f["kind"] for f in r.json()["files"]}
    assert kinds == {
        "module.xml": "module_xml",
        "lib/ctl.so": "thread_module",
        "descr.so": "thread_module",
        "proc.exe": "executable",
        "bin/static": "executable",
        "lib/libhelper.so": "library",
        "ioconfig.xml": "config",
        "layout.json": "layout",
        "robot.urdf": "urdf",
        "vars.glb": "glb",
        "meshes/arm.glb": "mesh",
        "meshes/a.stl": "mesh",
        "meshes/b.dae": "mesh",
        "meshes/c.obj": "mesh",
        "view.json": "json",
        "indurop/generated.h": "header",
        "notes.txt": "text",
        "README.md": "text",
    }


def test_a_refused_upload_after_a_good_one_changes_nothing(agent, elves):
    good = post_set(agent, *files_body(small_set(elves)))
    assert good.status_code == 201
    before = agent.stored()
    bad = {**small_set(elves), "lib/ctl.so": wrong_machine(elves.module, 3), "new.txt": b"n"}
    r = post_set(agent, *files_body(bad))
    assert r.status_code == 415
    assert agent.stored() == before


def test_refused_uploads_are_in_the_audit_log(agent, elves):
    r = post_set(agent, *files_body({**small_set(elves), "x.sh": b"!"}))
    assert r.status_code == 415
    line = agent.audit()[-1]
    assert line["action"] == "upload" and line["result"] == "error" and line["status"] == 415
    assert line["detail"] == r.json()["detail"]
    assert line["who"]["name"] == "admin" and line["who"]["role"] == "admin"


def test_the_raw_gzip_body_and_the_archive_part_give_the_same_set_as_files(agent, elves):
    files = small_set(elves)
    as_files = post_set(agent, *files_body(files))
    archive = tar_gz([(f"./{n}", c) for n, c in files.items()])
    as_body = post_set(agent, archive, GZ)
    body, ctype = multipart([("archive", "set.tar.gz", archive)])
    as_part = post_set(agent, body, ctype)
    assert as_files.status_code == as_body.status_code == as_part.status_code == 201
    assert as_files.json()["id"] == as_body.json()["id"] == as_part.json()["id"]
