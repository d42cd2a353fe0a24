"""An RGB image as PNG bytes, with the standard library's zlib alone (no imaging package needed to serve a picture).

>>> import numpy as np
>>> data = png_bytes(np.zeros((2, 3, 3), dtype=np.uint8))
>>> data[:8] == b"\\x89PNG\\r\\n\\x1a\\n", len(data) > 40
(True, True)
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
from numpy.typing import NDArray

SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_bytes(image: NDArray[np.uint8], level: int = 6) -> bytes:
    """``image`` (rows × cols × 3, uint8, the first row on top) as a PNG file's bytes; rows filtered by "up"
    (the difference from the row above), which suits ground textures; ``level`` is zlib's."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or 0 in image.shape:
        raise ValueError(f"png: an H×W×3 uint8 image, not {image.shape} {image.dtype}")
    rows, cols = image.shape[:2]
    up = image.astype(np.int16)
    up[1:] -= up[:-1].copy()
    filtered = np.empty((rows, cols * 3 + 1), dtype=np.uint8)
    filtered[:, 0] = 2
    filtered[0, 0] = 0
    filtered[:, 1:] = (up % 256).astype(np.uint8).reshape(rows, cols * 3)
    filtered[0, 1:] = image[0].reshape(-1)
    header = struct.pack(">IIBBBBB", cols, rows, 8, 2, 0, 0, 0)
    return (
        SIGNATURE
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(filtered.tobytes(), level))
        + _chunk(b"IEND", b"")
    )


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


__all__ = ["png_bytes"]
