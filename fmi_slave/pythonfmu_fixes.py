"""Workarounds for pythonfmu 0.7.0's export binary, each with the fact it answers (measured: see
docs/interop.md). The framework calls these; nothing else should need to know about them.

- On a Python exception in a callback the binary releases its references to the model class, the
  instance and its log queue once, and again when the instance is freed: two releases for one
  reference, which crashes the host later (a segfault at interpreter exit). ``balance_releases``
  takes one extra reference to each before the exception leaves Python.
- Each ``fmi2Instantiate`` re-executes the FMU script in its module's namespace and then releases
  one reference to the module's ``__dict__`` that it never took (it treats the borrowed result of
  ``PyModule_GetDict`` as owned). ``hold_module_dict`` takes one each time a model class statement
  runs: once at import, and once in every re-execution, just before the binary's extra release.
- The binary keeps its interpreter keeper (``PyState``) in a file-static ``shared_ptr`` that both a
  C++ static destructor and its unload hook ``finalizePythonInterpreter`` release. In a binary still
  loaded at ``exit()`` the static destructor runs first and the hook then decrements a counter inside
  the freed block: heap corruption that aborts some processes at exit. ``settle_binary_teardown``
  leaves both an empty pointer.
"""
from __future__ import annotations

import _ctypes
import ctypes
import os
import sys
from pathlib import Path
from typing import Any


def balance_releases(*objects: Any) -> None:
    """One extra reference to each object, for the binary to release after an exception."""
    for obj in objects:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))


def hold_module_dict(module_name: str) -> None:
    """Balance the binary's release of the script module's dict (call when a model class is made)."""
    module = sys.modules.get(module_name)
    if module is not None:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(module.__dict__))




_EXIT_CALL_REGISTERED: set[int] = set()  # dlopen handles of binaries whose keeper is released at exit


def settle_binary_teardown(resources: str | None) -> None:
    """Release the pythonfmu binary's interpreter keeper before ``exit()`` frees it and writes into it.

    The binary's ``finalizePythonInterpreter`` (its unload hook, exported) sets the file-static
    ``shared_ptr<PyState>`` to null. Called by us first, the C++ static destructor and the hook both
    find an empty pointer at exit, whatever the order glibc runs them in. When to call it depends on
    who made the interpreter:

    - the host did (any Python host; ``sys.orig_argv`` is never empty there): the keeper only holds a
      thread that has already ended, so it is released at once. Every ``fmi2Instantiate`` makes a
      new one, so this runs at every instantiation.
    - the binary did (a C host: its worker thread ran ``Py_Initialize``, which leaves
      ``sys.orig_argv`` empty): releasing now would finalize Python under this very call. The call is
      registered with ``__cxa_atexit`` instead, which runs it before the static destructor (entries
      run last-in first-out), and the binary is made ``RTLD_NODELETE`` so the address stays valid.

    Nothing happens when the binary is not loaded (the class instantiated in Python by a builder or
    a test) or not on Linux, where this was measured.
    """
    if sys.platform != "linux" or not resources:
        return
    # FMI 2.0 (pythonfmu) or FMI 3.0 (pythonfmu3, whose binary keeps its keeper the same way) layout; an
    # FMI 3 FMU's binary is our size-checking shim, with pythonfmu3's beside it: every one is tried
    binaries = sorted(p for folder in ("linux64", "x86_64-linux")
                      for p in (Path(resources).parent / "binaries" / folder).glob("*.so"))
    for path in binaries:
        _settle(path, host_made_python=bool(sys.orig_argv))


def _settle(path: Path, host_made_python: bool) -> None:
    """``settle_binary_teardown`` for one binary of the FMU (nothing if not loaded or not pythonfmu's)."""
    mode = os.RTLD_NOLOAD | (0 if host_made_python else os.RTLD_NODELETE)
    try:
        binary = ctypes.PyDLL(str(path), mode=mode)
    except OSError:  # not loaded in this process
        return
    try:
        finalize = binary.finalizePythonInterpreter
        if host_made_python:
            finalize()
        elif binary._handle not in _EXIT_CALL_REGISTERED:
            register = ctypes.CDLL(None)["__cxa_atexit"]
            register.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
            if register(ctypes.cast(finalize, ctypes.c_void_p), None, None) == 0:
                _EXIT_CALL_REGISTERED.add(binary._handle)
    except AttributeError:  # not a pythonfmu binary (the FMI 3 shim): nothing to settle
        pass
    finally:
        _ctypes.dlclose(binary._handle)  # only our own reference: unloading stays the host's affair
