"""The signing key of a run's own vehicle: fresh for each run, kept in the run's directory (mode 0600).

Why: the in-process vehicle listens on a UDP port any local process can reach; with a key only the run's own
client (which signs with it and checks the vehicle's signatures) commands it. A resumed run reads the key back, so
the restored vehicle and the new client still share it. The key is written only once the run's directory is made
(a run refused for bad input leaves nothing behind).

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> key = run_signing_key(d)
>>> keep_signing_key(d, key)
>>> len(key), run_signing_key(d) == key, oct((d / KEY_FILE).stat().st_mode & 0o777)
(32, True, '0o600')
"""

from __future__ import annotations

from pathlib import Path

from flight.signing import new_key, read_key_file, write_key_file

KEY_FILE = "signing.key"


def run_signing_key(run_dir: Path) -> bytes:
    """The run's key: the one in ``run_dir/signing.key`` (a resumed run), else a fresh one (not yet written)."""
    path = run_dir / KEY_FILE
    return read_key_file(path) if path.exists() else new_key()


def keep_signing_key(run_dir: Path, key: bytes | None) -> None:
    """Write ``key`` to ``run_dir/signing.key`` (0600) unless it is there already (or there is no key)."""
    path = run_dir / KEY_FILE
    if key is not None and not path.exists():
        write_key_file(path, key)
