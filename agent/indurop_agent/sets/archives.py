"""archives.py -- reading a .tar.gz that a client sent (a set upload, a backup to restore) without
trusting it: the decompressed stream is cut at a limit, so a gzip bomb stops there and not at the
disk's end; pax and GNU long-name headers over MAX_TAR_HEADER_BYTES are refused before tarfile
reads them whole into memory; and a member that is not a regular file or a folder is named.

Each caller raises its own error (uploads.UploadError, system.restore.RestoreError): `refuse` is
that error's constructor, called with an HTTP status and a message that says what to fix."""

from __future__ import annotations

import json
import tarfile
from collections.abc import Callable
from typing import IO

MAX_TAR_HEADER_BYTES = 64 << 10  # a pax or GNU long-name header larger than this is refused
LONG_HEADERS = (
    tarfile.XHDTYPE,
    tarfile.XGLTYPE,
    tarfile.SOLARIS_XHDTYPE,
    tarfile.GNUTYPE_LONGNAME,
    tarfile.GNUTYPE_LONGLINK,
)

Refuse = Callable[[int, str], Exception]


class LimitedReader:
    """A decompressed stream refused (413) once it grows past `limit` bytes."""

    def __init__(self, raw: IO[bytes], limit: int, refuse: Refuse, setting: str | None = None):
        self.raw, self.limit, self.seen, self.refuse, self.setting = raw, limit, 0, refuse, setting

    def read(self, n: int = -1) -> bytes:
        room = self.limit + 1 - self.seen
        data = self.raw.read(max(room if n is None or n < 0 else min(n, room), 0))
        self.seen += len(data)
        if self.seen > self.limit:
            which = f" ({self.setting})" if self.setting else ""
            raise self.refuse(413, f"the archive unpacks to more than {self.limit} bytes{which}")
        return data


def tar_stream(decompressed: IO[bytes], limit: int, refuse: Refuse, setting: str | None = None) -> tarfile.TarFile:
    """The archive's members, read once in order ("r|"), within `limit` decompressed bytes."""

    class BoundedTarInfo(tarfile.TarInfo):
        def _proc_member(self, tf):
            if self.type in LONG_HEADERS and self.size > MAX_TAR_HEADER_BYTES:
                raise refuse(
                    400,
                    f"the archive has a {self.size}-byte extended header; "
                    f"at most {MAX_TAR_HEADER_BYTES} bytes are accepted",
                )
            return super()._proc_member(tf)

    reader = LimitedReader(decompressed, limit, refuse, setting)
    return tarfile.open(fileobj=reader, mode="r|", tarinfo=BoundedTarInfo)


def type_problem(member: tarfile.TarInfo, what: str) -> str | None:
    """Why a member is not a regular file or a folder (`what` holds regular files only: "a set",
    "a backup"), or None."""
    only = f"{what} holds regular files only"
    if member.issym():
        return f"is a symbolic link (to {json.dumps(member.linkname)}); {only}"
    if member.islnk():
        return f"is a hard link (to {json.dumps(member.linkname)}); {only}"
    if member.ischr() or member.isblk():
        return f"is a device file; {only}"
    if member.isfifo():
        return f"is a FIFO; {only}"
    if member.issparse():
        return f"is a sparse file; {only}: pack it as a regular file"
    if not (member.isreg() or member.isdir()):
        return f"has tar type {member.type!r}; {only}"
    return None
