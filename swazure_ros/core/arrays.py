"""The array types the package's signatures name, defined once.

``FloatArray`` holds positions, vectors and distances (cm unless a function
says otherwise), ``IntArray`` indices and counts, ``IdArray`` FLS ids (int64, or
uint32 as the wire carries them), ``BoolArray`` masks. They are
aliases of :class:`numpy.typing.NDArray`, as scipy.spatial and numpy's own
stubs spell their arrays: the shape lives in each function's docstring.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
IdArray = NDArray[np.int64] | NDArray[np.uint32]
BoolArray = NDArray[np.bool_]

__all__ = ["BoolArray", "FloatArray", "IdArray", "IntArray"]
