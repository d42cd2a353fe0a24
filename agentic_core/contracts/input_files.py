"""Input files are regular files of bounded size: a FIFO, a device or a file larger than the limit is refused at once.

Reading ``/dev/zero`` or a FIFO nobody writes to would exhaust memory or block forever; a file of hundreds of
megabytes would take gigabytes to parse. Missions, scenes, tool files and statistics input are all checked here
before they are read. The limit is ``AGENTIC_UAV_MAX_INPUT_MB`` (default :data:`DEFAULT_MAX_MB`).

>>> import tempfile, os
>>> path = os.path.join(tempfile.mkdtemp(), "m.yaml")
>>> _ = open(path, "w").write("plan_id: p\\n")
>>> check_input_file(path, "mission")
11
>>> try:
...     check_input_file("/dev/zero", "mission")
... except InputFileError as exc:
...     print(exc)
/dev/zero: the mission is not a regular file (a character device); give a file
"""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping

from .errors import InputError

LIMIT_ENV = "AGENTIC_UAV_MAX_INPUT_MB"
DEFAULT_MAX_MB = 32.0


class InputFileError(InputError):
    """An input file that is not a regular file or is too large; ``reason`` says which, the message names the
    file."""

    def __init__(self, file: str, reason: str) -> None:
        super().__init__(f"{file}: {reason}" if file else reason)
        self.file = file
        self.reason = reason


def max_input_bytes(environ: Mapping[str, str] | None = None) -> int:
    """The size limit of an input file in bytes, from ``AGENTIC_UAV_MAX_INPUT_MB``."""
    raw = (os.environ if environ is None else environ).get(LIMIT_ENV, "").strip()
    try:
        megabytes = float(raw) if raw else DEFAULT_MAX_MB
    except ValueError:
        raise InputFileError("", f"{LIMIT_ENV}={raw!r} is not a number of megabytes") from None
    if not megabytes > 0:
        raise InputFileError("", f"{LIMIT_ENV}={raw!r} must be a positive number of megabytes")
    return int(megabytes * 2**20)


def _kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a plain file"


def check_input_file(path: str | os.PathLike[str], what: str, limit: int | None = None) -> int:
    """The size of ``path`` when it is a regular file within ``limit`` bytes (the environment's by default);
    :class:`InputFileError` otherwise, ``OSError`` when it cannot be looked at. Never opens the file, so a FIFO
    cannot block it."""
    name = os.fspath(path)
    info = os.stat(name)  # OSError (no such file...) is the caller's to word, as for its own read
    if not stat.S_ISREG(info.st_mode):
        raise InputFileError(name, f"the {what} is not a regular file ({_kind(info.st_mode)}); give a file")
    limit = max_input_bytes() if limit is None else limit
    if info.st_size > limit:
        raise InputFileError(
            name,
            f"the {what} is {info.st_size / 2**20:.1f} MB, over the {limit / 2**20:g} MB limit; "
            f"raise it with {LIMIT_ENV}=MEGABYTES if the file is meant to be this large",
        )
    return info.st_size


__all__ = ["DEFAULT_MAX_MB", "LIMIT_ENV", "InputFileError", "check_input_file", "max_input_bytes"]
