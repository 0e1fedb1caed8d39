"""Compiled cores verified before they load: a damaged extension must never reach ``dlopen``.

A build that compiles an FMU's hot cores writes ``resources/compiled_cores.sha256`` (the SHA-256 of
each extension, one ``<digest>  <path under resources/>`` line each). The FMU script calls
``verify_compiled_cores`` before it imports any core: every extension file under ``resources/``
whose bytes do not have the recorded digest (truncated, empty, replaced by another build's, or not
recorded at all) is not loaded, and neither is any other extension of the FMU (they cimport one
another); each module runs from the ``.py`` beside it, which gives the same
results bit for bit (the compiled cores are the same source), and each instance logs a warning
naming the file and why. A truncated shared library would otherwise crash the host with SIGBUS
while being mapped. An extension without its ``.py`` refuses the FMU with one message naming it.

Standard library only: this runs before anything else of the FMU is imported.
"""
from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys

DIGESTS = "compiled_cores.sha256"
FALLBACKS: list[str] = []  # why a module of this FMU runs as .py: logged by every instance
# the resources folders verified in this process: pythonfmu's binary runs the FMU script again when it
# instantiates, and an extension is loaded once per process (its first import), so once is enough
_VERIFIED: set[str] = set()


class _SourceInstead(importlib.abc.MetaPathFinder):
    """Imports the named modules from their ``.py`` files, never from the extension beside them."""

    def __init__(self, sources: dict[str, str]):
        self.sources = sources

    def find_spec(self, name, path=None, target=None):
        source = self.sources.get(name)
        return importlib.util.spec_from_file_location(name, source) if source else None


def _sha256(path: str) -> str | None:
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def recorded_digests(resources: str) -> dict[str, str]:
    """Path under ``resources`` -> recorded SHA-256 (empty: nothing was compiled, or no readable list)."""
    try:
        with open(os.path.join(resources, DIGESTS), encoding="utf-8") as f:
            lines = [line.split(None, 1) for line in f if line.strip()]
    except (OSError, UnicodeDecodeError):
        return {}
    return {rest.strip(): digest for digest, rest in (p for p in lines if len(p) == 2)}


def extension_files(resources: str) -> list[str]:
    """Every file under ``resources`` that this interpreter's import system would load as an extension."""
    found = []
    for folder, _, names in os.walk(resources):
        found += [os.path.relpath(os.path.join(folder, n), resources).replace(os.sep, "/") for n in names
                  if n.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))]
    return sorted(found)


def problems(resources: str) -> dict[str, str]:
    """Extension file (path under ``resources``) -> why it must not be loaded."""
    recorded = recorded_digests(resources)
    out = {}
    for rel in extension_files(resources):
        expected = recorded.get(rel)
        size = os.path.getsize(os.path.join(resources, rel))
        actual = _sha256(os.path.join(resources, rel))
        if expected is None:
            out[rel] = f"not listed in {DIGESTS} ({size} bytes; not built with this FMU)"
        elif actual != expected:
            out[rel] = f"its SHA-256 is not the one recorded in {DIGESTS} ({size} bytes: truncated, damaged or replaced)"
    return out


def _module_and_source(resources: str, rel: str) -> tuple[str, str]:
    stem = next(rel[:-len(s)] for s in importlib.machinery.EXTENSION_SUFFIXES if rel.endswith(s))
    return stem.replace("/", "."), os.path.join(resources, stem + ".py")


def verify_compiled_cores(model: str, resources: str) -> None:
    """Keep every extension under ``resources`` whose digest does not match from loading (its ``.py``
    runs instead; ``FALLBACKS`` says why); ImportError if one has no ``.py`` to run instead.

    The fallback takes the whole set: compiled cores ``cimport`` one another, and an extension whose
    cimported module runs as ``.py`` fails to import (``no attribute '__pyx_capi__'``). So when one
    extension is not loaded, none of this FMU's extensions is: whatever cimports what now or later."""
    if resources in _VERIFIED:
        return
    damaged = problems(resources)
    if not damaged:
        _VERIFIED.add(resources)
        return
    sources = {}
    first = next(iter(damaged))
    for rel in extension_files(resources):
        module, source = _module_and_source(resources, rel)
        why = damaged.get(rel) or f"resources/{first} is not loaded, and compiled cores cimport one another"
        if not os.path.isfile(source):
            raise ImportError(f"{model} FMU: the compiled core resources/{rel} is not loaded: {why}; and there "
                              "is no .py to run instead. Rebuild the FMU (sotc-cosim build)")
        sources[module] = source
        FALLBACKS.append(f"{model} FMU: resources/{rel} is not loaded: {why}; "
                         f"{module.split('.')[-1]}.py runs instead (same results, slower)")
    sys.meta_path.insert(0, _SourceInstead(sources))
    _VERIFIED.add(resources)
