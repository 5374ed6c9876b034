"""scipy's LAPACK routines called through :mod:`ctypes`, the GIL released (private).

numpy's ``linalg`` holds the GIL in ``lstsq``, and ``scipy.linalg.lapack``'s wrappers hold
it in ``dgeqrf``: the channels' threads of a fit would take turns. A :mod:`ctypes` call
releases it. The routines are those scipy exports for Cython
(:mod:`scipy.linalg.cython_lapack`), every argument by reference (Fortran).
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

__all__ = ["lapack_function"]

_KINDS = {
    "i": ctypes.POINTER(ctypes.c_int),
    "d": ctypes.POINTER(ctypes.c_double),
    "p": ctypes.c_void_p,  # an array's data (``ndarray.ctypes.data``)
}


@functools.cache
def lapack_function(name: str, args: str) -> Any:
    """The LAPACK routine ``name`` of scipy's LAPACK as a :mod:`ctypes` function.

    Parameters
    ----------
    name : str
        Routine (``"dgeqrf"``).
    args : str
        One letter an argument: ``i`` a pointer to an int, ``d`` to a double, ``p`` an
        array's data.
    """
    # deferred: scipy.linalg (about 0.2 s to import) only when a fit solves through it
    from scipy.linalg import cython_lapack

    capsule = cython_lapack.__pyx_capi__[name]
    api = ctypes.pythonapi
    api.PyCapsule_GetName.restype = ctypes.c_char_p
    api.PyCapsule_GetName.argtypes = [ctypes.py_object]
    api.PyCapsule_GetPointer.restype = ctypes.c_void_p
    api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
    address = api.PyCapsule_GetPointer(capsule, api.PyCapsule_GetName(capsule))
    return ctypes.CFUNCTYPE(None, *(_KINDS[k] for k in args))(address)
