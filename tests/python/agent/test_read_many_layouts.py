"""test_read_many_layouts.py -- POST /variables/read keeps the segment and each list of paths resolved
(a read plan) from one read to the next (docs/programming.md "Monitoring"); against a real irpd and a
real agent, the same paths read again after the layout changed give the new layout's values: after an
online change that converts, moves and adds variables, and after a managed restart onto a layout laid
out afresh (a new segment and a new connection), never the old offsets' or the old file's.  The
fixtures are tests/cpp/online/'s (test_online_layout.py)."""

from __future__ import annotations

import time

import pytest
from test_online_layout import ONLINE, Cell, set_files

pytestmark = pytest.mark.skipif(
    not (ONLINE / "modules" / "oc_cv_v2.so").exists(), reason=f"the online-change fixtures are not built ({ONLINE})"
)


def read(cell: Cell, paths: list[str]) -> tuple[dict, dict]:
    """{path: (type, value)} of the paths read, {path: message} of those that were not."""
    r = cell.post("/variables/read", json={"paths": paths})
    assert r.status_code == 200, r.text
    answer = r.json()
    return {v["path"]: (v["type"], v["value"]) for v in answer["values"]}, {
        e["path"]: e["message"] for e in answer["errors"]
    }


def test_the_same_paths_read_after_an_online_change_give_the_converted_moved_and_added_variables(tmp_path):
    cell = Cell(tmp_path, "cv1", ("cv", "oc_cv_v1.so"))
    try:
        paths = ["cv.wide", "cv.f", "cv.arr[2]", "cv.arr[4]", "cv.fb.added", "cv.narrow"]
        deadline = time.monotonic() + 5
        while read(cell, paths)[0]["cv.wide"][1] != -1234:
            assert time.monotonic() < deadline, "the cv module does not run"
            time.sleep(0.05)
        values, errors = read(cell, paths)
        assert values["cv.wide"] == ("int16_t", -1234) and values["cv.f"] == ("float", 1.5), values
        assert set(errors) == {"cv.arr[4]", "cv.fb.added"}, errors

        stored = cell.upload(set_files("cv2", ("cv", "oc_cv_v2.so")))
        r = cell.post(f"/sets/{stored['id']}/activate")
        assert r.status_code == 200, r.text
        values, errors = read(cell, paths)  # cv.wide moved 64 -> 512, cv.f 256 -> 640; two added
        assert errors == {}, errors
        assert values["cv.wide"] == ("int32_t", -1234) and values["cv.f"] == ("double", 1.5), values
        assert values["cv.arr[2]"] == ("int32_t", 30) and values["cv.arr[4]"] == ("int32_t", 0), values
        assert values["cv.fb.added"][0] == "double" and values["cv.narrow"] == ("int32_t", 70000), values
    finally:
        cell.close()


def test_the_same_paths_read_after_a_managed_restart_give_the_new_segments_values(tmp_path):
    cell = Cell(tmp_path)  # oc_v1: oc.counter at offset 0, no oc.added
    try:
        paths = ["oc.counter", "oc.added"]
        values, errors = read(cell, paths)
        assert values["oc.counter"][0] == "uint64_t" and "oc.added" in errors, (values, errors)

        stored = cell.upload(set_files("reordered", ("counter", "oc_counter_reordered.so")))
        r = cell.post(f"/sets/{stored['id']}/activate", json={"mode": "auto"})
        assert r.status_code == 200, r.text
        assert r.json()["mode"] == "restart", r.json()
        values, errors = read(cell, paths)  # oc.added at offset 0 now, oc.counter at 64, in a new segment
        assert errors == {} and values["oc.added"][0] == "double", (values, errors)
        first = values["oc.counter"][1]
        deadline = time.monotonic() + 5
        while read(cell, paths)[0]["oc.counter"][1] == first:
            assert time.monotonic() < deadline, "oc.counter does not move: read from the old segment or offset"
            time.sleep(0.05)
        assert read(cell, ["oc.counter"])[0]["oc.counter"][1] <= cell.get("/variables/oc.counter").json()["value"]
    finally:
        cell.close()
