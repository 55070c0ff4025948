"""jaxlib's CPU LAPACK kernels without importing all of ``scipy.linalg``.

jaxlib takes its LAPACK function table from SciPy: the first LU, Cholesky or triangular solve
that JAX lowers for the CPU (and every lowering of a stored, exported function) imports
``scipy.linalg.cython_blas`` and ``scipy.linalg.cython_lapack`` by name and reads their
``__pyx_capi__``. Importing them the usual way runs ``scipy/linalg/__init__.py``, which imports
all of SciPy's linear algebra, a sizeable part of a warm start (docs/performance.md, "Time from
import to the table"); the two extension modules themselves load in milliseconds.

:func:`preload` loads the two extension modules from their files under their full names, so
that jaxlib finds them in ``sys.modules``; ``scipy.linalg`` itself is imported when something
asks for it, and then gets its ``cython_blas``/``cython_lapack`` attributes as usual. It does
nothing when ``scipy.linalg`` is imported already, when ``PROLEG_PRELOAD_LAPACK=0``, or when
anything about SciPy's layout differs from what it expects (then jaxlib imports them itself).
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys

_SUBMODULES = ("cython_blas", "cython_lapack")  # cython_lapack's functions take cython_blas's types


def preload() -> bool:
    """Load ``scipy.linalg.cython_blas`` and ``cython_lapack`` without ``scipy.linalg``'s package
    code; True when they were loaded here."""
    names = [f"scipy.linalg.{s}" for s in _SUBMODULES]
    if os.environ.get("PROLEG_PRELOAD_LAPACK", "1") == "0" or "scipy.linalg" in sys.modules or any(n in sys.modules for n in names):
        return False
    try:
        spec = importlib.util.find_spec("scipy")
        if spec is None or not spec.submodule_search_locations:
            return False
        folder = os.path.join(list(spec.submodule_search_locations)[0], "linalg")
        files = []
        for sub in _SUBMODULES:
            found = [f for f in os.listdir(folder) if f.startswith(sub + ".") and f.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))]
            if len(found) != 1:
                return False
            files.append(os.path.join(folder, found[0]))
        import scipy  # noqa: F401  (the package's own __init__ is light: ~3 ms)

        for name, file in zip(names, files):
            mspec = importlib.util.spec_from_file_location(name, file)
            module = importlib.util.module_from_spec(mspec)
            sys.modules[name] = module
            mspec.loader.exec_module(module)
    except Exception:  # any surprise: undo, and let jaxlib import scipy.linalg itself
        for name in names:
            sys.modules.pop(name, None)
        return False
    sys.meta_path.insert(0, _AttachOnImport())
    return True


class _AttachOnImport(importlib.abc.MetaPathFinder):
    """When ``scipy.linalg`` is imported, set its ``cython_blas``/``cython_lapack`` attributes to
    the preloaded modules (the import system sets a submodule's attribute only when it loads the
    submodule itself). It stays in ``sys.meta_path`` and answers None to everything else (taking
    itself out while the import system iterates that list would make it skip the next finder)."""

    done = False

    def find_spec(self, fullname, path, target=None):
        if fullname != "scipy.linalg" or self.done:
            return None
        self.done = True
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            for sub in _SUBMODULES:
                if not hasattr(module, sub) and f"scipy.linalg.{sub}" in sys.modules:
                    setattr(module, sub, sys.modules[f"scipy.linalg.{sub}"])

        spec.loader.exec_module = exec_module
        return spec
