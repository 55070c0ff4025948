"""Compiled functions kept across processes: traced and lowered once per model, not per process.

JAX's persistent compilation cache (set up by ``proleg/__init__.py`` in ``PROLEG_CACHE_DIR``)
saves the XLA backend compile on a warm start, but every new process still traces the model's
functions to a jaxpr and lowers it to StableHLO before it can look the executable up, and for a
simulation that is most of a warm start (bench/compile_cache.py --table). :func:`cached_jit`
wraps a function like ``jax.jit`` and, for concrete arguments, keeps the lowered function on
disk (``jax.export``) under a key of everything the traced computation depends on; a later
process with the same key loads it, and XLA finds the executable in the persistent cache.

The key (:func:`fingerprint`) must change whenever the traced computation can: it hashes

- proleg's own source files (:func:`source_hash`) and the versions of Python, jax and jaxlib,
  the backend, and the JAX options that change tracing (x64, promotion, matmul precision);
- the wrapped function's name, the static arguments, and the structure of the pytree arguments
  with its static data (a System's topology: the Model with its parts, elements, numbers and
  the user's Python functions), with the shape and dtype of every array leaf;
- every user function met on the way by its code (bytecode, constants, nested code), default
  arguments, closure cells and the module globals it reads, recursively.

What cannot be hashed for sure (a module that is neither the standard library nor an installed
package nor proleg, an object of an unknown extension type) makes the whole key unknown, and
the call is an ordinary ``jax.jit`` call: when in doubt, miss. Under tracing (``jit``,
``vmap``, ``grad`` of a caller) the wrapper is plain ``jax.jit``.

``PROLEG_CACHE_DIR=""`` turns this cache off with JAX's. ``proleg.compile_cache.stats`` counts
traces (misses) and loads (hits) in this process; ``proleg cache info | clear`` shows and
empties the folder.

The store (:mod:`proleg.cache_store`; issue 34, after Git's and SQLite's object stores and
ccache). One folder is shared by every process on the machine (pytest-xdist workers, a study's
worker pool, notebooks); it holds ``export/`` (traced functions), ``trail/`` (prefetch lists)
and ``xla/`` (XLA executables: JAX's persistent compilation cache is routed through the same
store, :func:`proleg.cache_store.install_jax_cache`). It promises, for every entry:

- **Atomic publication.** An entry is written to a temporary file in its own folder, fsync'ed,
  then renamed over its name (``os.replace``). A reader sees the whole old entry, the whole
  new one, or none, never a part; a process killed at any point of a write leaves at most a
  ``*.tmp`` file, which no reader opens and a later scan deletes after 15 minutes.
- **Keys by content, verified on read.** Names derive from the key (a hash of everything the
  computation depends on; JAX's own key for executables). Each file starts with a header:
  magic, format version, the full key, payload length and sha256 of the payload, all checked
  before the payload is used. A truncated, bit-flipped, foreign (another format, an older
  proleg's pickle) or misplaced (another key's) entry is deleted with one
  :class:`~proleg.errors.ProlegWarning` per entry and rebuilt: never a crash, never a wrong
  executable handed to XLA. JAX's own file cache, by contrast, writes in place, checks only
  zlib's Adler-32, and warns about a damaged entry on every run without rewriting it.
  JAX's keys for executables include the cache folder (its compile options name it), so a
  copied or moved cache recompiles its executables; the old ones age out under the cap.
- **Concurrent writers.** Processes that build the same key write their own temporary files
  and rename them in turn: the last writer wins, with contents equal to the others' (the
  same key means the same computation; an executable's entry also records its compile time
  in whole seconds, which JAX reads only for its statistics).
- **Failure turns writing off, not the run.** A full disk, a read-only folder or one that cannot
  be created makes the first failed write warn once and stop writing in this process; entries
  already there are still read, and the run goes on.
- **Size cap.** ``PROLEG_CACHE_MAX_BYTES`` (bytes, or ``500M``/``2G``; default 2 GiB) bounds the
  folder: after a write that may pass it, the folder is scanned (``os.scandir``, O(files); on a
  process's first write, when its running total passes the cap, and after each 1/16 of the cap
  written) and the least recently used entries deleted down to 90 % of it. A read refreshes an
  entry's mtime (atime is unreliable under noatime/relatime). Processes writing at once may
  overshoot the cap by up to 1/16 of it each until one of them scans. Only the store's own files
  are counted or deleted; anything else in the folder is left alone.

XLA options by kind of function (:data:`XLA_OPTIONS`, :func:`xla_options`). Most of a cold
start is XLA's CPU backend compiling many small kernels, and two of its defaults cost far more
compile time than they give back on proleg's small dense matrices (the README's double
pendulum, HyQ leg drop and 7-link chain, bench/compile_cache.py --table; docs/performance.md):

- ``"loop"`` (the integration loops, run thousands of steps): XLA's MLIR fusion emitters off
  (``xla_cpu_use_fusion_emitters``), the classic LLVM IR emitters instead: about a quarter less
  compile time for the same time per step, within the run-to-run spread.
- ``"once"`` (initial conditions, post-processing, Jacobians: a few calls per run): also LLVM's
  optimisation level 0: these compile 3–5× faster and run 2–3× slower, microseconds per call.

``PROLEG_XLA_OPTIONS=default`` compiles everything with XLA's own defaults.

Trails (:func:`trail`): an analysis (``simulate``) names what determines the executables it
will load; the first run records them in ``trail/<key>.entry``, and a later process
starts loading the last one it will need (the step loop, the largest) in a background thread
while the analysis computes its initial conditions. XLA deserialises executables without
Python's lock, so the loading overlaps the initial conditions even on two cores.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import enum
import functools
import hashlib
import os
import pickle
import re
import struct
import sys
import sysconfig
import threading
import types
import weakref
from collections import OrderedDict

import jax
import numpy as np

from . import cache_store

_PKG_DIR = os.path.dirname(os.path.abspath(__file__))

#: ``compiler_options`` for ``jax.jit`` by kind of function (module docstring: the measurements).
XLA_OPTIONS = {
    "loop": {"xla_cpu_use_fusion_emitters": False},
    "once": {"xla_cpu_use_fusion_emitters": False, "xla_backend_optimization_level": 0},
}


def xla_options(kind: str | None) -> dict | None:
    """The ``compiler_options`` for a function of ``kind`` ("loop", "once"; None: XLA's defaults),
    or None when ``PROLEG_XLA_OPTIONS=default``. They are measured for XLA's CPU compiler and
    given to CPU compiles only (a GPU compile gets XLA's defaults)."""
    if kind is None or os.environ.get("PROLEG_XLA_OPTIONS", "").strip().lower() == "default":
        return None
    return dict(XLA_OPTIONS[kind])


#: Options this process's XLA refused as unknown ("No such compile option"): left out of later
#: compiles. XLA retires flags: jaxlib 0.11 no longer has ``xla_cpu_use_fusion_emitters`` (seen on
#: the H100 host, JAX 0.11.2, 25 Nov 2026), which is measured and set for jaxlib 0.10.
refused_options: set[str] = set()


def compile_lowered(lowered, options: dict | None):
    """``lowered.compile(compiler_options=options)`` without the options this XLA does not know:
    each one it refuses is dropped (and remembered in :data:`refused_options`) and the compile
    retried, so a JAX release that retires a flag costs its speed-up, not the run. Any other
    error (a known option with a bad value, say) is raised."""
    while True:
        opts = {k: v for k, v in (options or {}).items() if k not in refused_options} or None
        try:
            return lowered.compile(compiler_options=opts)
        except Exception as exc:  # jax.errors.JaxRuntimeError: INVALID_ARGUMENT
            m = re.search(r"No such compile option: '([^']+)'", str(exc))
            if m is None or opts is None or m.group(1) not in opts:
                raise
            refused_options.add(m.group(1))


def jit(fn=None, *, xla: str = "once", static_argnums=()):
    """Like ``jax.jit(fn, static_argnums=...)``, compiled with :func:`xla_options` of ``xla`` when
    called with concrete arguments (the compiled executables are kept in this process, not on
    disk); under an outer ``jit``/``vmap``/``grad`` it is plain ``jax.jit`` (XLA takes
    ``compiler_options`` only from the outermost compile). Usable as a decorator."""
    if fn is None:
        return lambda f: jit(f, xla=xla, static_argnums=static_argnums)
    return CachedJit(fn, static_argnums, xla, disk=False)


stats = {"exported": 0, "loaded": 0, "unkeyed": 0, "prefetched": 0, "shared": 0, "verified": 0}


def cache_dir() -> str | None:
    """proleg's persistent-cache folder: ``PROLEG_CACHE_DIR``, else ``$XDG_CACHE_HOME/proleg/jax``
    (``~/.cache/proleg/jax``); None when ``PROLEG_CACHE_DIR=""`` turns caching off."""
    path = os.environ.get("PROLEG_CACHE_DIR")
    if path is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        path = os.path.join(base, "proleg", "jax")
    return path or None


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """sha256 of every ``.py`` file of the proleg package (path and content)."""
    h = hashlib.sha256()
    for root, dirs, files in os.walk(_PKG_DIR):
        dirs.sort()
        for f in sorted(files):
            if f.endswith(".py"):
                p = os.path.join(root, f)
                h.update(os.path.relpath(p, _PKG_DIR).encode())
                with open(p, "rb") as fh:
                    h.update(hashlib.sha256(fh.read()).digest())
    return h.hexdigest()


class Unkeyable(Exception):
    """An object :func:`fingerprint` cannot hash for sure (the cache then misses)."""


def _stable_roots() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    return tuple(os.path.realpath(paths[k]) for k in ("stdlib", "platstdlib", "purelib", "platlib") if k in paths)


_STABLE = _stable_roots()


def _module_token(mod: types.ModuleType) -> tuple:
    """A module a function reads: proleg's (covered by source_hash), the standard library or an
    installed package (name and version); anything else (a user's module, whose attributes may
    change) is unkeyable."""
    name = mod.__name__
    top = name.split(".")[0]
    if top == "proleg":
        return ("module", name)
    if top in sys.builtin_module_names or top in getattr(sys, "stdlib_module_names", ()):
        return ("module", name)
    f = getattr(mod, "__file__", None)
    if f and os.path.realpath(f).startswith(_STABLE):
        return ("module", name, str(getattr(sys.modules.get(top), "__version__", "")))
    raise Unkeyable(f"module {name}")


def _stable_module(modname) -> bool:
    if not isinstance(modname, str):
        return False
    mod = sys.modules.get(modname)
    if mod is None:
        return False
    try:
        _module_token(mod)
    except Unkeyable:
        return False
    return modname.split(".")[0] != "__main__"


class _Hasher:
    """Deterministic structural hash of static data and user code (see the module docstring)."""

    def __init__(self, structural: bool = False):
        self.h = hashlib.sha256()
        self.seen: dict[tuple, int] = {}  # (id, abstract) → visit index (cycles and shared objects)
        self.keep = []  # keep visited objects alive so ids stay unique
        # Structural mode (:func:`structure_fingerprint`): inside an object whose class sets
        # ``_numbers_are_data`` (a System's Topology, a coordinate set's static data), floats and
        # float arrays are hashed by type and shape only; what :func:`perturbed` does not descend
        # into (code, closures, sets, ``_fingerprint_state`` objects) stays exact.
        self.structural = structural
        self.abstract = False

    def put(self, *parts):
        for p in parts:
            b = p if isinstance(p, bytes) else str(p).encode()
            self.h.update(struct.pack("<Q", len(b)))
            self.h.update(b)

    def visit(self, x):  # noqa: C901 (one dispatch table)
        if self.abstract:
            if not _descends(x):  # what perturbed() leaves as it is must be hashed exactly
                self.abstract = False
                try:
                    self.visit(x)
                finally:
                    self.abstract = True
                return
            if isinstance(x, (float, complex, np.floating, np.complexfloating)):
                self.put("number", type(x).__name__)
                return
        if x is None or isinstance(x, (bool, int, float, complex, str, bytes)):
            self.put(type(x).__name__, repr(x))
            return
        if isinstance(x, enum.Enum):
            self.put("enum", type(x).__module__, type(x).__qualname__, x.name)
            return
        if self.structural and not self.abstract and getattr(type(x), "_numbers_are_data", False):
            self.put("structure-of")
            self.abstract = True
            try:
                self.visit(x)
            finally:
                self.abstract = False
            return
        k = (id(x), self.abstract)
        if k in self.seen:
            self.put("ref", self.seen[k])
            return
        self.seen[k] = len(self.seen)
        self.keep.append(x)
        if hasattr(type(x), "_fingerprint_state"):  # a class that says what defines it (not its caches)
            self.visit_type(type(x))
            self.visit(x._fingerprint_state())
        elif type(x) is object:  # a sentinel: no state, compared by identity
            self.put("sentinel")
        elif isinstance(x, np.generic):
            self.put("npscalar", x.dtype.str, x.tobytes())
        elif isinstance(x, np.ndarray):
            self.put("ndarray", x.dtype.str, x.shape)
            if self.abstract and x.dtype.kind in "fc":
                return  # a float array of a topology: its numbers are data (structure_fingerprint)
            if x.dtype.hasobject:
                for e in x.ravel():
                    self.visit(e)
            else:
                self.put(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, jax.Array):
            if isinstance(x, jax.core.Tracer):
                raise Unkeyable("a traced array in static data")
            self.visit(np.asarray(x))
        elif isinstance(x, (tuple, list)):
            self.put(type(x).__qualname__, len(x))
            if type(x) not in (tuple, list):
                self.visit_type(type(x))
            for e in x:
                self.visit(e)
        elif isinstance(x, dict):
            self.put(type(x).__qualname__, len(x))
            if type(x) is not dict:
                self.visit_type(type(x))
            for kk, v in x.items():
                self.visit_exact(kk)  # keys are not perturbed
                self.visit(v)
        elif isinstance(x, (set, frozenset)):
            subs = sorted(fingerprint(e) for e in x)
            self.put(type(x).__qualname__, *subs)
        elif isinstance(x, types.ModuleType):
            self.put(*_module_token(x))
        elif isinstance(x, type):
            self.visit_type(x)
        elif isinstance(x, functools.partial):
            self.put("partial")
            self.visit(x.func)
            self.visit(x.args)
            self.visit(x.keywords)
        elif isinstance(x, types.MethodType):
            self.put("method")
            self.visit(x.__func__)
            self.visit(x.__self__)
        elif isinstance(x, types.FunctionType):
            self.visit_function(x)
        elif isinstance(x, types.CodeType):
            self.visit_code(x)
        elif isinstance(x, (types.BuiltinFunctionType, np.ufunc)):
            mod = getattr(x, "__module__", None) or getattr(getattr(x, "__self__", None), "__name__", None)
            if isinstance(x, np.ufunc):
                mod = "numpy"
            if not _stable_module(mod) and mod != "builtins":
                raise Unkeyable(f"builtin {x!r}")
            self.put("builtin", mod, getattr(x, "__qualname__", x.__name__))
        elif isinstance(x, CachedJit):
            self.put("cached_jit", x.static_argnums)
            self.visit(x.fn)
        elif callable(x) and hasattr(x, "__wrapped__") and hasattr(x, "lower"):  # jax.jit objects
            self.put("jit", type(x).__qualname__)
            self.visit(x.__wrapped__)
        elif isinstance(x, np.dtype):
            self.put("dtype", x.str)
        elif isinstance(x, re.Pattern):
            self.put("re", x.pattern, x.flags)
        elif isinstance(x, (slice, range)):
            self.put(type(x).__name__)
            self.visit((x.start, x.stop, x.step))
        elif isinstance(x, jax.tree_util.PyTreeDef):
            self.visit_treedef(x)
        elif isinstance(x, jax.ShapeDtypeStruct):
            self.put("sds", x.shape, np.dtype(x.dtype).str, getattr(x, "weak_type", False))
        elif dataclasses.is_dataclass(x) or hasattr(x, "__dict__") or hasattr(type(x), "__slots__"):
            self.visit_object(x)
        else:
            raise Unkeyable(f"object of type {type(x).__module__}.{type(x).__qualname__}")

    def visit_exact(self, x):
        abstract, self.abstract = self.abstract, False
        try:
            self.visit(x)
        finally:
            self.abstract = abstract

    def visit_type(self, t: type):
        mod = t.__module__
        self.put("type", mod, t.__qualname__)
        if mod.split(".")[0] == "proleg" or _stable_module(mod) or mod == "builtins":
            return
        if (id(t), "type") in self.seen:
            self.put("ref", self.seen[(id(t), "type")])
            return
        self.seen[(id(t), "type")] = len(self.seen)
        self.keep.append(t)
        for b in t.__mro__[1:]:
            self.visit_type(b)
        for name, v in t.__dict__.items():
            if name in ("__dict__", "__weakref__", "__doc__", "__module__", "__qualname__"):
                continue
            self.put(name)
            if isinstance(v, (staticmethod, classmethod)):
                v = v.__func__
            if isinstance(v, property):
                v = (v.fget, v.fset)
            try:
                self.visit(v)
            except Unkeyable:
                if isinstance(v, (types.FunctionType, tuple)):
                    raise
                self.put("unhashed attribute")  # a descriptor or slot member: its values are visited per object

    def visit_object(self, x):
        self.visit_type(type(x))
        d = getattr(x, "__dict__", None)
        fixed = getattr(type(x), "_structure_fields", ()) if self.abstract else ()
        if d is not None:
            if self.abstract:  # the fields a trace never reads (a builder's notes): not structure
                d = {k: v for k, v in d.items() if _traced_field(type(x), k)}
            self.visit({k: v for k, v in d.items() if k not in fixed})
            for k in fixed:  # numbers that are structure (a one-hot selector, a sign): exact
                self.put("structure field", k)
                self.visit_exact(d.get(k))
        for cls in type(x).__mro__:
            for s in cls.__dict__.get("__slots__", ()):
                if s in ("__dict__", "__weakref__"):
                    continue
                self.put("slot", s)
                self.visit(getattr(x, s, "<unset>"))

    def visit_function(self, f: types.FunctionType):
        mod = f.__module__ or ""
        self.put("function", mod, f.__qualname__)
        library = mod.split(".")[0] != "proleg" and _stable_module(mod)
        if library:  # an installed package's function (e.g. jax.vmap's wrapper): name and version
            self.put(*_module_token(sys.modules[mod]))
        else:
            self.visit_code(f.__code__)
        self.visit(f.__defaults__)
        self.visit(f.__kwdefaults__)
        if f.__closure__:
            for c in f.__closure__:
                try:
                    self.visit(c.cell_contents)
                except ValueError:  # empty cell
                    self.put("empty cell")
        if library or mod.split(".")[0] == "proleg":
            return  # module-level names of proleg's code are in source_hash; a package's, in its version
        g = f.__globals__
        for name in sorted(_global_names(f.__code__)):
            if name in g:
                self.put("global", name)
                self.visit(g[name])

    def visit_code(self, c: types.CodeType):
        self.put("code", c.co_name, c.co_argcount, c.co_kwonlyargcount, c.co_flags, c.co_code, c.co_names, c.co_varnames, c.co_freevars)
        for k in c.co_consts:
            self.visit(k)

    def visit_treedef(self, td):
        self.put("treedef", td.num_leaves, td.num_nodes)
        nd = td.node_data()
        if nd is not None:
            t, aux = nd
            self.visit_type(t)
            self.visit(aux)
        for ch in td.children():
            self.visit_treedef(ch)


def _descends(x) -> bool:
    """Whether :func:`perturbed` looks inside ``x`` (numbers, containers, arrays, plain objects);
    anything else (code, closures, types, modules, sets, enums, objects with a
    ``_fingerprint_state``) is kept as it is, so the structural hash keeps it exact."""
    if x is None or isinstance(x, (bool, int, str, bytes, np.integer, np.bool_, enum.Enum)):
        return False
    if isinstance(x, (float, complex, np.floating, np.complexfloating, list, tuple, dict, np.ndarray)):
        return True
    if isinstance(x, jax.Array):
        return not isinstance(x, jax.core.Tracer)
    if isinstance(x, (types.MethodType, functools.partial)):
        return True
    if hasattr(type(x), "_fingerprint_state") or getattr(type(x), "_numbers_are_structure", False) or isinstance(x, (
        type, types.ModuleType, types.FunctionType, types.CodeType, types.BuiltinFunctionType, np.ufunc,
        CachedJit, set, frozenset, np.dtype, re.Pattern, slice, range, jax.tree_util.PyTreeDef,
        jax.ShapeDtypeStruct,
    )):
        return False
    if callable(x) and hasattr(x, "__wrapped__") and hasattr(x, "lower"):  # jax.jit objects
        return False
    return dataclasses.is_dataclass(x) or hasattr(x, "__dict__") or hasattr(type(x), "__slots__")


def _traced_field(cls, name: str) -> bool:
    """Whether a trace may read attribute ``name`` of a ``cls`` object inside a topology: a class
    lists what it holds for a trace (``_traced_fields``, e.g. the Model's elements, not a
    builder's notes attached to it) or what no trace reads (``_untraced_fields``, e.g. the
    Topology's degree-of-freedom report)."""
    keep = getattr(cls, "_traced_fields", None)
    if keep is not None and name not in keep:
        return False
    return name not in getattr(cls, "_untraced_fields", ())


def _perturb_number(x):
    """The number every float of a topology becomes in :func:`perturbed`: sign flipped, scaled
    and shifted, so that a branch on a sign, on zero or on a magnitude traces differently."""
    return -(1.3183 * x + 0.0727)


def _zero_number(x):
    """The second perturbation: every number zero (a branch on ``x == 0`` or on a sign, when the
    model's own numbers are all on one side of it)."""
    return 0.0 * x


class _Perturber:
    """A copy of a pytree's static data with every number inside a ``_numbers_are_data`` object
    changed (:func:`perturbed`); it descends exactly where the structural hash abstracts."""

    def __init__(self, change=_perturb_number):
        self.memo: dict[int, object] = {}
        self.keep = []
        self.change = change

    def outside(self, x):
        """Static data outside any topology: containers are copied only to reach one."""
        if getattr(type(x), "_numbers_are_data", False):
            return self.inside(x)
        if type(x) is tuple:
            return tuple(self.outside(e) for e in x)
        if type(x) is list:
            return [self.outside(e) for e in x]
        if type(x) is dict:
            return {k: self.outside(v) for k, v in x.items()}
        if isinstance(x, jax.tree_util.PyTreeDef):
            return _map_treedef(x, self.outside)
        if _descends(x) and not isinstance(x, (float, complex, np.generic, np.ndarray, jax.Array)):
            return self._copy_object(x, self.outside)
        return x

    def inside(self, x):  # noqa: C901 (mirrors _Hasher.visit)
        if not _descends(x):
            return x
        if isinstance(x, (float, complex, np.floating, np.complexfloating)):
            return type(x)(self.change(x))
        k = id(x)
        if k in self.memo:
            return self.memo[k]
        self.keep.append(x)
        if isinstance(x, np.ndarray):
            if x.dtype.kind in "fc":
                out = np.asarray(self.change(x), dtype=x.dtype)
            elif x.dtype.hasobject:
                out = np.empty_like(x)
                for i, e in enumerate(x.ravel()):
                    out.ravel()[i] = self.inside(e)
            else:
                out = x
            if not x.flags.writeable and out is not x:
                out.flags.writeable = False
        elif isinstance(x, jax.Array):
            a = np.asarray(x)
            out = jax.numpy.asarray(self.inside(a)) if a.dtype.kind in "fc" else x
        elif isinstance(x, list):
            out = copy.copy(x)
            self.memo[k] = out
            out[:] = [self.inside(e) for e in x]
        elif isinstance(x, tuple):
            items = [self.inside(e) for e in x]
            out = type(x)(*items) if hasattr(x, "_fields") else (tuple(items) if type(x) is tuple else type(x)(items))
        elif isinstance(x, dict):
            out = copy.copy(x)
            self.memo[k] = out
            for kk in list(x):
                out[kk] = self.inside(x[kk])
        elif isinstance(x, types.MethodType):
            out = types.MethodType(x.__func__, self.inside(x.__self__))
        elif isinstance(x, functools.partial):
            out = functools.partial(x.func, *self.inside(x.args), **self.inside(x.keywords or {}))
        else:
            out = self._copy_object(x, self.inside)
        self.memo[k] = out
        return out

    def _copy_object(self, x, walk):
        k = id(x)
        if k in self.memo:
            return self.memo[k]
        out = copy.copy(x)
        self.memo[k] = out
        self.keep.append(x)
        d = getattr(x, "__dict__", None)
        fixed = getattr(type(x), "_structure_fields", ()) if walk == self.inside else ()
        if d is not None:
            for name, v in list(d.items()):
                if name not in fixed and (walk != self.inside or _traced_field(type(x), name)):
                    object.__setattr__(out, name, walk(v))
        for cls in type(x).__mro__:
            for sl in cls.__dict__.get("__slots__", ()):
                if sl not in ("__dict__", "__weakref__") and hasattr(x, sl):
                    object.__setattr__(out, sl, walk(getattr(x, sl)))
        return out


def _map_treedef(td, f):
    """``td`` with the static data of every node replaced by ``f(data)``."""
    nd = td.node_data()
    kids = [_map_treedef(c, f) for c in td.children()]
    if nd is None:
        return td
    t, aux = nd
    from jax._src import tree_util as _tu

    return td.from_node_data_and_children(_tu.default_registry, (t, f(aux)), kids)


def perturbed(static, treedef, change=_perturb_number):
    """(static arguments, treedef) with every number inside their ``_numbers_are_data`` objects
    (a System's topology and what it holds) replaced by ``change(number)``: a trace that reads
    none of them is equal, constant for constant, to the original's
    (:meth:`CachedJit.trace_difference`)."""
    p = _Perturber(change)
    return tuple(p.outside(s) for s in static), p.outside(treedef)


def numbers_difference(j1, trace, static, treedef) -> str:
    """What differs between the trace ``j1`` and ``trace(static', treedef')`` of the model with its
    topology numbers changed, twice (:func:`_perturb_number`, :func:`_zero_number`: a branch on a
    sign or on zero shows in one); "" when nothing does. A changed model that fails to trace
    counts as a difference (when in doubt, miss)."""
    for change in (_perturb_number, _zero_number):
        try:
            j2 = trace(*perturbed(static, treedef, change))
        except Exception as exc:  # noqa: BLE001 (a perturbed model may not trace at all)
            return f"the model with its numbers changed ({change.__name__}) does not trace: {type(exc).__name__}: {exc}"[:300]
        why = _jaxpr_difference(j1, j2)
        if why:
            return why
    return ""


def structure_fingerprint(*objs) -> str:
    """:func:`fingerprint` with the numbers inside ``_numbers_are_data`` objects left out: the
    same for two assemblies of one model structure with other numbers (issue 42)."""
    hs = _Hasher(structural=True)
    for o in objs:
        hs.visit(o)
    return hs.h.hexdigest()


def _global_names(code: types.CodeType) -> set:
    names = set(code.co_names)
    for k in code.co_consts:
        if isinstance(k, types.CodeType):
            names |= _global_names(k)
    return names


def fingerprint(*objs) -> str:
    """sha256 hex digest of ``objs`` (static data, pytree structures, user functions); raises
    :class:`Unkeyable` for what cannot be hashed for sure."""
    hs = _Hasher()
    for o in objs:
        hs.visit(o)
    return hs.h.hexdigest()


def _platform() -> str:
    """The platform this call compiles for (jax.default_device's, else the default backend's)."""
    dev = jax.config.jax_default_device
    if dev is None:
        return jax.default_backend()
    return str(getattr(dev, "platform", dev))


def _environment_key() -> tuple:
    import jaxlib

    cfg = jax.config
    dev = jax.devices(_platform())[0]
    return (
        "proleg-export-1", source_hash(), sys.version, jax.__version__, jaxlib.__version__,
        getattr(dev, "platform", str(dev)), getattr(dev, "device_kind", ""),
        cfg.jax_enable_x64, cfg.jax_numpy_rank_promotion, cfg.jax_numpy_dtype_promotion,
        str(cfg.jax_default_matmul_precision), os.environ.get("XLA_FLAGS", ""),
    )


def _aval(x) -> tuple:
    """(shape, dtype, weak type) of a leaf as JAX will see it; TypeError for other leaves."""
    if isinstance(x, (jax.ShapeDtypeStruct, jax.Array)):
        return (tuple(x.shape), np.dtype(x.dtype).str, bool(getattr(x, "weak_type", False)))
    if isinstance(x, (np.ndarray, np.generic)):
        return (tuple(x.shape), np.dtype(jax.dtypes.canonicalize_dtype(x.dtype)).str, False)
    if isinstance(x, bool):
        return ((), np.dtype(bool).str, False)
    if isinstance(x, (int, float, complex)):
        return ((), np.dtype(jax.dtypes.canonicalize_dtype(type(x))).str, True)
    raise TypeError(f"leaf of type {type(x).__name__}")


def _specs(avals) -> list:
    """Abstract arguments of (shape, dtype, weak type) triples (:func:`_aval`)."""
    return [jax.ShapeDtypeStruct(s, np.dtype(d), weak_type=w) for s, d, w in avals]


def _compile_exported(exported, specs, options):
    """The executable of a ``jax.export`` function for ``specs``, compiled with ``options``."""
    return compile_lowered(jax.jit(exported.call).lower(*specs), options)


class CachedJit:
    """``jax.jit(fn, static_argnums=...)`` whose trace and lowering is kept on disk for concrete
    arguments (see the module docstring). Call it as ``fn``; :meth:`compile_for` compiles for
    arguments given as arrays or ``jax.ShapeDtypeStruct`` (e.g. in a background thread)."""

    MEMO = 16  # compiled executables kept per function in this process (each maps its machine code)

    def __init__(self, fn, static_argnums=(), xla: str | None = "once", disk: bool = True):
        self.fn = fn
        self.static_argnums = tuple(static_argnums)
        self.options = xla_options(xla)  # given to XLA at the top-level compiles made here
        self.disk = disk
        self.jitted = fn if hasattr(fn, "lower") else jax.jit(fn, static_argnums=self.static_argnums)
        self.name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', getattr(fn, '__name__', '?'))}"
        self._memo: OrderedDict = OrderedDict()
        self._smemo: OrderedDict = OrderedDict()  # structure key → executable shared by its models
        self._lock = threading.Lock()
        functools.update_wrapper(self, fn)
        _INSTANCES.add(self)

    def _split(self, args):
        static = tuple(args[i] for i in self.static_argnums)
        dyn = tuple(a for i, a in enumerate(args) if i not in self.static_argnums)
        return static, dyn

    def __call__(self, *args):
        if tracing(args):  # inside another trace: inlined (traced_raw's reason)
            return traced_raw(self)(*args)
        entry = self._entry(args)
        if entry is None:
            return self.jitted(*args)
        return entry(*jax.tree_util.tree_leaves(self._split(args)[1]))

    def compile_for(self, *args):
        """A callable of ``fn``'s (non-static) arguments, compiled for these shapes; ``args`` as in
        a call, arrays or ``jax.ShapeDtypeStruct``."""
        entry = self._entry(args)
        if entry is None:
            return compile_lowered(self.jitted.lower(*args), self.options if _platform() == "cpu" else None)
        treedef = jax.tree_util.tree_structure(self._split(args)[1])

        def call(*dyn_args):
            leaves, td = jax.tree_util.tree_flatten(dyn_args)
            if td != treedef:
                raise TypeError("compiled for other arguments")
            return entry(*leaves)

        return call

    # -- internals ---------------------------------------------------------------------------
    def _entry(self, args):
        """The compiled flat function for these arguments, or None (plain jit)."""
        if _platform() != "cpu":  # single runs go to the CPU (analyses/placement.py)
            return None
        path = cache_dir() if self.disk else None
        if path is None and self.options is None:
            return None
        static, dyn = self._split(args)
        leaves, treedef = jax.tree_util.tree_flatten(dyn)
        if tracing((leaves, static)):
            return None
        try:
            avals = tuple(_aval(x) for x in leaves)
            mkey = (treedef, static, avals)
            hash(mkey)
        except TypeError:
            return None
        with self._lock:
            if mkey in self._memo:
                self._memo.move_to_end(mkey)
                return self._memo[mkey]
        entry = self._build(path, static, treedef, avals)
        with self._lock:
            self._memo[mkey] = entry
            while len(self._memo) > self.MEMO:
                self._memo.popitem(last=False)
        return entry

    def _build(self, path, static, treedef, avals):
        specs = _specs(avals)
        key = skey = None
        try:
            key = fingerprint(_environment_key(), self.name, self.fn, static, treedef, avals)
            if _share_structures():
                skey = structure_fingerprint(_environment_key(), self.name, self.fn, static, treedef, avals)
        except Unkeyable as exc:
            stats["unkeyed"] += 1
            stats["why_unkeyed"] = (stats.get("why_unkeyed", []) + [f"{self.name}: {exc}"])[-10:]
        st = cache_store.get(path) if path is not None and key is not None else None
        if skey is not None and skey != key:
            entry = self._shared(st, static, treedef, specs, key, skey)
            if entry is not None:
                return entry
        if st is None:  # not on disk: compiled here, with this function's XLA options
            return compile_lowered(jax.jit(self._flat(static, treedef)).lower(*specs), self.options)
        return self._stored(st, key, static, treedef, specs)

    def _stored(self, st, key, static, treedef, specs, tag=""):
        """The executable kept on disk under ``key`` (loaded, or traced, exported and saved)."""
        avals = tuple((tuple(x.shape), np.dtype(x.dtype).str, bool(x.weak_type)) for x in specs)
        name = self._entry_name(key, tag)
        _Trail.note(name, key, avals, self.options)
        compiled = _Trail.take(name)
        if compiled is not None:
            stats["loaded"] += 1
            stats["prefetched"] += 1
            return compiled
        exported = _load(st, "export", name, key)
        if exported is not None:
            try:
                compiled = _compile_exported(exported, specs, self.options)
                stats["loaded"] += 1
                return compiled
            except Exception as exc:  # an entry that verified but does not compile: rebuilt
                st.discard(st.path("export", name), f"does not compile: {type(exc).__name__}: {exc}")
        exported = self._export(static, treedef, specs)
        if exported is None:
            return None
        _save(st, name, key, exported)
        stats["exported"] += 1
        return _compile_exported(exported, specs, self.options)

    def _entry_name(self, key, tag=""):
        stem = "".join(c if c.isalnum() or c == "_" else "_" for c in getattr(self.fn, "__name__", "fn"))
        return f"{stem}-{tag}{key[:40 - len(tag)]}"

    def _shared(self, st, static, treedef, specs, key, skey):
        """The executable every model of this structure shares (issue 42), or None: the trace
        reads a number of the topology, or only one set of numbers has been seen so far.

        The first model of a structure is compiled under its full key, as before, and recorded
        as the structure's first; the first model with other numbers decides, once: its trace
        is compared with the trace of a copy whose every topology number is changed
        (:meth:`_numbers_free`). Equal traces mean the numbers reach the computation only as
        arguments (``params``), so one executable serves every model of the structure."""
        with self._lock:
            hit = self._smemo.get(skey)
        if hit is not None:
            stats["shared"] += 1
            return hit
        free = _Verdicts.get(st, skey)
        if free is None:
            first = _Verdicts.first(st, skey)
            if first is None or first == key:
                _Verdicts.set_first(st, skey, key)
                return None
            free = self._numbers_free(static, treedef, specs)
            _Verdicts.set(st, skey, free)
            if free and st is not None:  # the first model's export is the structure's: no new trace
                exported = _load(st, "export", self._entry_name(first), first)
                if exported is not None:
                    _save(st, self._entry_name(skey, "s"), skey, exported)
        if not free:
            return None
        if st is None:
            entry = compile_lowered(jax.jit(self._flat(static, treedef)).lower(*specs), self.options)
        else:
            entry = self._stored(st, skey, static, treedef, specs, tag="s")
        if entry is None:
            return None
        stats["shared"] += 1
        with self._lock:
            self._smemo[skey] = entry
            while len(self._smemo) > self.MEMO:
                self._smemo.popitem(last=False)
        return entry

    def _numbers_free(self, static, treedef, specs) -> bool:
        """Whether tracing reads no number of the topology (:meth:`trace_difference` is "")."""
        stats["verified"] += 1
        why = self.trace_difference(static, treedef, specs)
        if why:
            stats["why_not_shared"] = (stats.get("why_not_shared", []) + [f"{self.name}: {why}"])[-10:]
        return not why

    def trace_difference(self, static, treedef, specs) -> str:
        """"" when the trace with every topology number changed (:func:`perturbed`) equals the
        trace as it is, equation for equation and constant for constant; else what differs. A
        perturbed model that fails to trace counts as a difference (when in doubt, miss)."""
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            j1, out = jax.make_jaxpr(self._flat(static, treedef), return_shape=True)(*specs)
            if _holds_data(jax.tree_util.tree_structure(out)):  # a System in the result: its topology is the first model's
                return "the result holds a model's static data"
            return numbers_difference(j1, lambda s2, td2: jax.make_jaxpr(self._flat(s2, td2))(*specs), static, treedef)

    def _flat(self, static, treedef):
        """``fn`` as a function of the flat leaves of its non-static arguments."""
        sidx = self.static_argnums
        call = traced_raw(self)

        def flat(*lv):
            dyn = list(jax.tree_util.tree_unflatten(treedef, lv))
            it_s, it_d = iter(static), iter(dyn)
            full = [next(it_s) if i in sidx else next(it_d) for i in range(len(static) + len(dyn))]
            return call(*full)

        flat.__name__ = flat.__qualname__ = getattr(self.fn, "__name__", "flat")  # JAX's logs name the function
        return flat

    def _export(self, static, treedef, specs):
        from jax import export

        try:
            return export.export(jax.jit(self._flat(static, treedef)), platforms=("cpu",))(*specs)
        except Exception:  # an export limitation (or the user's error, which plain jit raises again)
            return None


def reads_numbers(fn: CachedJit, *args) -> str:
    """What tracing ``fn(*args)`` reads of the numbers of the topologies in ``args`` (a System's
    masses, marker positions, gains, ...), as the first equation or constant that changes when
    they all change; "" when it reads none, so that every model of this structure shares one
    compiled ``fn`` (issue 42). The guard the tests run over the built-in robots."""
    static, dyn = fn._split(args)
    leaves, treedef = jax.tree_util.tree_flatten(dyn)
    return fn.trace_difference(static, treedef, _specs(tuple(_aval(x) for x in leaves)))


def structure_key(fn: CachedJit, *args) -> str:
    """The key under which the models of one structure share ``fn`` compiled for ``args``
    (:func:`structure_fingerprint` of what :class:`CachedJit` keys): equal for two assemblies
    that differ only in their numbers."""
    static, dyn = fn._split(args)
    leaves, treedef = jax.tree_util.tree_flatten(dyn)
    avals = tuple(_aval(x) for x in leaves)
    return structure_fingerprint(_environment_key(), fn.name, fn.fn, static, treedef, avals)


def _share_structures() -> bool:
    """Whether models of one structure share executables (``PROLEG_SHARE_STRUCTURES=0``: never)."""
    return os.environ.get("PROLEG_SHARE_STRUCTURES", "1").strip() not in ("0", "false", "no", "off")


_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def _holds_data(td) -> bool:
    """Whether a pytree structure carries static data with model numbers (``_numbers_are_data``)
    in a node: a shared executable would hand every model the first one's."""
    nd = td.node_data()
    if nd is not None:
        found = []

        def look(x):
            if getattr(type(x), "_numbers_are_data", False):
                found.append(x)
            return x

        _walk_static(nd[1], look)
        if found:
            return True
    return any(_holds_data(c) for c in td.children())


def _walk_static(x, f, depth=0):
    f(x)
    if depth > 4:
        return
    if isinstance(x, (tuple, list)):
        for e in x:
            _walk_static(e, f, depth + 1)
    elif isinstance(x, dict):
        for e in x.values():
            _walk_static(e, f, depth + 1)


def jaxpr_consts(closed) -> list:
    """The constants of a ClosedJaxpr and of every jaxpr nested in its equations (loop bodies,
    branches, inner jits), in order: a number can hide in any of them."""
    from jax.extend.core import ClosedJaxpr, Jaxpr

    out, stack = [], [closed]
    while stack:
        j = stack.pop()
        if isinstance(j, ClosedJaxpr):
            out += list(j.consts)
            j = j.jaxpr
        nested = []
        for eqn in j.eqns:
            for v in eqn.params.values():
                for x in (v if isinstance(v, (tuple, list)) else (v,)):
                    if isinstance(x, (ClosedJaxpr, Jaxpr)):
                        nested.append(x)
        stack.extend(reversed(nested))
    return out


def _jaxpr_difference(j1, j2) -> str:
    """"" when two closed jaxprs are the same computation with the same constants, else what differs."""
    a, b = _ADDRESS.sub("", str(j1.jaxpr)), _ADDRESS.sub("", str(j2.jaxpr))
    if a != b:
        la, lb = a.splitlines(), b.splitlines()
        i = next((k for k, (x, y) in enumerate(zip(la, lb)) if x != y), min(len(la), len(lb)))
        return f"equation {i} differs: {la[i].strip()[:160] if i < len(la) else '(end)'}"
    c1, c2 = jaxpr_consts(j1), jaxpr_consts(j2)
    if len(c1) != len(c2):
        return "constant count differs"
    for i, (x, y) in enumerate(zip(c1, c2)):
        x, y = np.asarray(x), np.asarray(y)
        if x.shape != y.shape or x.dtype != y.dtype or x.tobytes() != y.tobytes():
            return f"constant {i} {x.dtype}{list(x.shape)} differs"
    return ""


class _Verdicts:
    """Per structure key: whether its models share one executable (True/False), or the full key
    of the first model seen (not decided yet); kept in this process and in the store ("struct")."""

    lock = threading.Lock()
    memo: dict = {}

    @classmethod
    def _record(cls, st, skey):
        with cls.lock:
            if skey in cls.memo:
                return cls.memo[skey]
        rec = _load(st, "struct", skey[:40], skey) if st is not None else None
        if rec is not None:
            with cls.lock:
                cls.memo[skey] = rec
        return rec

    @classmethod
    def _put(cls, st, skey, rec):
        with cls.lock:
            cls.memo[skey] = rec
        if st is not None:
            st.write("struct", skey[:40], skey, pickle.dumps(rec))

    @classmethod
    def get(cls, st, skey):
        rec = cls._record(st, skey)
        return rec.get("free") if isinstance(rec, dict) else None

    @classmethod
    def first(cls, st, skey):
        rec = cls._record(st, skey)
        return rec.get("first") if isinstance(rec, dict) else None

    @classmethod
    def set_first(cls, st, skey, key):
        if cls.first(st, skey) is None:
            cls._put(st, skey, {"first": key})

    @classmethod
    def set(cls, st, skey, free: bool):
        cls._put(st, skey, {"free": bool(free)})


def tracing(tree) -> bool:
    """Whether any leaf of ``tree`` is a JAX tracer (the call is inside a jit, vmap or grad)."""
    return any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(tree))


def traced_raw(fn):
    """The Python function behind a jit wrapper (``jax.jit``, :class:`CachedJit`, equinox's
    ``filter_jit``), to be called inside a trace that is compiled as a whole.

    A nested jit of a long-lived function keeps its arguments: JAX's trace caches are keyed
    weakly on the function but hold the argument structure (a System's topology, with its
    model) and the traced jaxpr strongly, and ``trace_to_jaxpr``'s cache has no size limit. A
    process that simulates one new model after another then grew 10-12 MiB per model for as
    long as it ran, although proleg keeps only :attr:`CachedJit.MEMO` executables per function
    (bench/memory_maps.py; issue 34). Called inline, the function leaves nothing behind once
    the outer trace's own entry is dropped; the compiled program is the same, as XLA inlines
    nested calls. A ``jax.jit`` object given to :class:`CachedJit` keeps its own jit (its
    static arguments are its own)."""
    if isinstance(fn, CachedJit):
        return fn.jitted if hasattr(fn.fn, "lower") else fn.fn
    if hasattr(fn, "lower") and hasattr(fn, "__wrapped__"):
        return fn.__wrapped__
    return fn


def _load(st, kind, name, key):
    """The unpickled entry ``name`` of ``kind``, or None (absent or damaged: the store deletes a
    damaged entry with one warning, and so is one that verifies but does not unpickle)."""
    blob = st.read(kind, name, key)
    if blob is None:
        return None
    try:
        return pickle.loads(blob)
    except Exception as exc:
        st.discard(st.path(kind, name), f"does not unpickle: {type(exc).__name__}: {exc}")
        return None


def _save(st, name, key, exported) -> None:
    try:
        blob = pickle.dumps(dataclasses.replace(exported, _get_vjp=None))
    except Exception:  # an output structure that does not pickle: keep it in this process only
        return
    st.write("export", name, key, blob)


_INSTANCES = weakref.WeakSet()


class _Trail:
    """The executables loaded under one :func:`trail` (see the module docstring). Builds are
    noted from any thread while a trail is open (the outputs' compile runs in a second thread);
    a prefetched executable is used only for the same entry, whose key covers its function,
    static arguments and argument shapes, so a stale trail costs a wasted load, never a wrong one."""

    lock = threading.Lock()
    open: list = []  # the trails being recorded: [name, ...] lists, in the order of first use
    entries: dict = {}  # entry name -> (key, avals, options) of the builds noted
    prefetched: dict = {}  # entry name -> Future of the compiled executable
    pool = None

    @classmethod
    def note(cls, name, key, avals, options):
        with cls.lock:
            for names in cls.open:
                if name not in names:
                    names.append(name)
            if cls.open:
                cls.entries[name] = (key, avals, options)

    @classmethod
    def take(cls, name):
        """The prefetched executable of entry ``name``, or None (none started: the caller loads it)."""
        with cls.lock:
            fut = cls.prefetched.pop(name, None)
        if fut is None or fut.cancel():  # cancelled before it started: load it here
            return None
        try:
            return fut.result()
        except Exception:  # the caller loads it (and reports a bad entry)
            return None

    @classmethod
    def prefetch(cls, st, name, key, avals, options) -> bool:
        """Start loading entry ``name`` in the background thread; False if it is already under way."""
        from concurrent.futures import ThreadPoolExecutor

        dev = jax.config.jax_default_device  # the device this analysis runs on (thread-local)

        def load():
            exported = _load(st, "export", name, key)
            if exported is None:
                return None
            with jax.default_device(dev):
                return _compile_exported(exported, _specs(avals), options)

        with cls.lock:
            if name in cls.prefetched:
                return False
            if cls.pool is None:
                cls.pool = ThreadPoolExecutor(1, thread_name_prefix="proleg-prefetch")
            cls.prefetched[name] = cls.pool.submit(load)
            return True


@contextlib.contextmanager
def trail(tree, *key_parts, prefetch: int = 1):
    """Record the executables loaded inside this block under a key of the structure and shapes
    of ``tree`` (not its values: a System) and of ``key_parts`` (the analysis's static options);
    on entry, start loading the last ``prefetch`` of those that a previous process recorded
    under the same key, in a background thread. A no-op without a disk cache, off the CPU, and
    for what cannot be keyed."""
    path = cache_dir()
    if path is None or _platform() != "cpu":
        yield
        return
    try:
        leaves, treedef = jax.tree_util.tree_flatten(tree)
        key = fingerprint(("proleg-trail-2",), _environment_key(), treedef, tuple(_aval(x) for x in leaves), *key_parts)
    except (Unkeyable, TypeError):
        yield
        return
    st = cache_store.get(path)
    tname = key[:40]
    before, started = _load(st, "trail", tname, key), []
    try:
        for name, ekey, avals, options in list(before or [])[::-1][:prefetch]:
            if os.path.exists(st.path("export", name)) and _Trail.prefetch(st, name, ekey, avals, options):
                started.append(name)
    except Exception as exc:  # verified, yet not a trail this version writes: rewritten below
        st.discard(st.path("trail", tname), f"not a trail: {type(exc).__name__}: {exc}")
        before = None
    names: list = []
    with _Trail.lock:
        _Trail.open.append(names)
    try:
        yield
    finally:
        with _Trail.lock:
            _Trail.open.remove(names)
            record = [(n, *_Trail.entries[n]) for n in names]
            if not _Trail.open:
                _Trail.entries.clear()
            for n in started:  # prefetched for nothing (a stale trail): let it go
                fut = _Trail.prefetched.pop(n, None)
                if fut is not None:
                    fut.cancel()
        if record and [r[0] for r in record] != [b[0] for b in before or []]:
            st.write("trail", tname, key, pickle.dumps(record))


def clear() -> None:
    """Drop the executables every :func:`cached_jit` function holds in this process (with
    ``jax.clear_caches()``, e.g. when a long test run approaches the kernel's memory-map limit)."""
    for f in list(_INSTANCES):
        with f._lock:
            f._memo.clear()
            f._smemo.clear()


def cached_jit(fn=None, *, static_argnums=(), xla: str | None = "once"):
    """Decorator: :class:`CachedJit` (``jax.jit`` plus the on-disk cache of the lowered function),
    compiled with :func:`xla_options` of ``xla`` ("once" or "loop"; a ``fn`` that is already a
    ``jax.jit`` object keeps its own options when called plainly)."""
    if fn is None:
        return lambda f: CachedJit(f, static_argnums, xla)
    return CachedJit(fn, static_argnums, xla)
