"""Linear RGBA images as EXR files (OpenEXR package), one place for the renders, the stored
references and the demo. Rows are top row first, as Cycles writes them."""
from __future__ import annotations

import numpy as np


def read_rgba(path) -> np.ndarray:
    """(H, W, 4) float32."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        return np.array(f.channels()["RGBA"].pixels, dtype=np.float32)


def write_rgba(path, rgba: np.ndarray, half: bool = False) -> None:
    """ZIP-compressed RGBA EXR, float32, or half-float with ``half`` (the stored references: three
    significant digits, far below their noise)."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    data = np.ascontiguousarray(rgba, dtype=np.float16 if half else np.float32)
    with OpenEXR.File(header, {"RGBA": data}) as f:
        f.write(str(path))
