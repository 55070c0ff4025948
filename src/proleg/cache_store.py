"""The on-disk store behind proleg's compile cache: atomic, verified, capped (issue 34 item 2).

One folder (``PROLEG_CACHE_DIR``, default ``~/.cache/proleg/jax``) is shared by every process of
every user session on the machine: pytest-xdist workers, a study's worker pool, notebooks. Its
entries are files ``<kind>/<name>.entry`` with kinds

- ``export``: traced and lowered functions (``jax.export``, :mod:`proleg.compile_cache`);
- ``trail``: the executables an analysis loaded, for the next process's prefetch;
- ``xla``: XLA executables of JAX's persistent compilation cache, which proleg routes through
  this store (:func:`install_jax_cache`).

Each entry is a header (magic, format version, its full key, payload length, sha256 of the
payload) and the payload. The guarantees, and how they are kept, are listed in
:mod:`proleg.compile_cache`'s docstring; this module implements them.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import secrets
import struct
import threading
import time
import warnings

MAGIC = b"PROLEGC\x00"
VERSION = 1
_HEAD = struct.Struct("<8sHH")  # magic, format version, key length
_TAIL = struct.Struct("<Q32s")  # payload length, sha256 of the payload
SUFFIX = ".entry"
KINDS = ("export", "trail", "xla", "struct")
#: Default size cap [bytes] (PROLEG_CACHE_MAX_BYTES): a few hundred models' executables.
DEFAULT_MAX_BYTES = 2 * 1024**3
#: After an eviction the store holds at most this fraction of the cap, so that the next writes
#: do not each rescan the folder.
LOW_WATER = 0.9
#: A temporary file older than this [s] is a killed writer's leftover and is deleted by a scan.
STALE_TMP_S = 900.0
_TMP = re.compile(r"\.tmp$")  # in a kind's folder: a write in progress (or a killed one)
_JAX_LEGACY = re.compile(r"-[0-9a-f]{64}-(cache|atime)$")  # JAX's own LRUCache files (older proleg)

stats = {"written": 0, "read": 0, "corrupt": 0, "evicted": 0, "write_failed": 0}
_warned: set = set()
_warn_lock = threading.Lock()


class CorruptEntry(Exception):
    """An entry whose header, key, length or checksum does not match (the reason is the text)."""


def encode(key: str, payload: bytes) -> bytes:
    """The bytes of an entry: header (magic, version, key, payload length, sha256) + payload."""
    k = key.encode()
    return b"".join((_HEAD.pack(MAGIC, VERSION, len(k)), k, _TAIL.pack(len(payload), hashlib.sha256(payload).digest()), payload))


def decode(key: str, blob: bytes) -> bytes:
    """The payload of entry ``blob`` written under ``key``; :class:`CorruptEntry` if the file is not
    an entry of this format (foreign), belongs to another key, is truncated or fails its checksum."""
    if len(blob) < _HEAD.size:
        raise CorruptEntry(f"truncated header ({len(blob)} bytes)")
    magic, version, klen = _HEAD.unpack_from(blob)
    if magic != MAGIC:
        raise CorruptEntry("not a proleg cache entry (bad magic)")
    if version != VERSION:
        raise CorruptEntry(f"format version {version}, expected {VERSION}")
    off = _HEAD.size + klen
    if len(blob) < off + _TAIL.size:
        raise CorruptEntry("truncated header")
    if blob[_HEAD.size:off] != key.encode():
        raise CorruptEntry("written for another key")
    n, digest = _TAIL.unpack_from(blob, off)
    payload = blob[off + _TAIL.size :]
    if len(payload) != n:
        raise CorruptEntry(f"payload has {len(payload)} bytes, header says {n}")
    if hashlib.sha256(payload).digest() != digest:
        raise CorruptEntry("checksum mismatch")
    return payload


def verify_file(path: str) -> str | None:
    """Why the entry file ``path`` is not a valid entry of its name (None: valid). The key is read
    from the header, and the file's name must be the one the store gives that key (a foreign or
    misplaced file fails); then :func:`decode` checks length and checksum."""
    try:
        with open(path, "rb") as fh:
            blob = fh.read()
    except OSError as exc:
        return f"{type(exc).__name__}: {exc}"
    try:
        if len(blob) < _HEAD.size:
            raise CorruptEntry(f"truncated header ({len(blob)} bytes)")
        _m, _v, klen = _HEAD.unpack_from(blob)
        key = blob[_HEAD.size : _HEAD.size + klen].decode(errors="replace")
        decode(key, blob)
    except CorruptEntry as exc:
        return str(exc)
    stem = os.path.basename(path).removesuffix(SUFFIX)
    kind = os.path.basename(os.path.dirname(path))
    ok = {"xla": stem == entry_name(key), "trail": stem == key[:40], "export": stem.endswith("-" + key[:40])}.get(kind, False)
    return None if ok else f"a {kind} entry named {stem!r} holds key {key[:50]!r}"


def warn_once(tag, message: str) -> None:
    """One :class:`~proleg.errors.ProlegWarning` per ``tag`` in this process."""
    from .errors import ProlegWarning

    with _warn_lock:
        if tag in _warned:
            return
        _warned.add(tag)
    warnings.warn(message, ProlegWarning, stacklevel=3)


_SIZE = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*([kmgt]?)(i?b)?\s*$", re.IGNORECASE)


def max_bytes() -> int:
    """The size cap [bytes]: ``PROLEG_CACHE_MAX_BYTES`` (a number of bytes, or with a binary
    suffix: ``500M``, ``2G``, ``2GiB``; ``0`` stores nothing new), default
    :data:`DEFAULT_MAX_BYTES`. A value that is not a size is reported once and the default used."""
    raw = os.environ.get("PROLEG_CACHE_MAX_BYTES", "").strip()
    if not raw:
        return DEFAULT_MAX_BYTES
    m = _SIZE.match(raw)
    if m is None:
        warn_once(("max_bytes", raw), f"PROLEG_CACHE_MAX_BYTES={raw!r} is not a size; expected bytes or a number with "
                  f"K, M, G or T (e.g. 2G). Using the default {DEFAULT_MAX_BYTES} bytes.")
        return DEFAULT_MAX_BYTES
    return int(float(m.group(1)) * 1024 ** " kmgt".index((m.group(2) or " ").lower()))


def entry_name(text: str) -> str:
    """A file name (without suffix) for ``text``: its safe characters, shortened with a hash when long."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", text).lstrip(".")
    if len(name) > 150:
        name = f"{name[:100]}-{hashlib.sha256(text.encode()).hexdigest()[:40]}"
    return name


class Store:
    """The entries under one cache folder ``root`` (one instance per folder and process: :func:`get`)."""

    def __init__(self, root: str):
        self.root = root
        self.writable = True  # False after a write failed (full disk, read-only or uncreatable folder)
        self._lock = threading.Lock()
        self._total: int | None = None  # bytes in the folder at the last scan (None: not scanned yet)
        self._since_scan = 0  # bytes this process wrote since

    def path(self, kind: str, name: str) -> str:
        return os.path.join(self.root, kind, name + SUFFIX)

    # -- read ----------------------------------------------------------------------------------
    def read(self, kind: str, name: str, key: str) -> bytes | None:
        """The payload stored under ``key``, or None (absent, or damaged: then deleted with one
        warning). A hit refreshes the entry's recency for the size cap."""
        path = self.path(kind, name)
        try:
            with open(path, "rb") as fh:
                blob = fh.read()
                ino = os.fstat(fh.fileno()).st_ino
        except (FileNotFoundError, NotADirectoryError):  # absent, or no folder (reported by the first write)
            return None
        except OSError as exc:  # a directory in its place, no permission, an I/O error: a miss, reported
            self.discard(path, f"{type(exc).__name__}: {exc}")
            return None
        try:
            payload = decode(key, blob)
        except CorruptEntry as exc:
            self.discard(path, str(exc), ino)
            return None
        with contextlib.suppress(OSError):  # recency for the LRU cap (atime is unreliable: noatime)
            os.utime(path)
        stats["read"] += 1
        return payload

    def discard(self, path: str, reason: str, ino: int | None = None) -> None:
        """Delete a damaged entry (if it is still the file read: a concurrent writer may have
        replaced it with a good one) and warn once for it."""
        stats["corrupt"] += 1
        with contextlib.suppress(OSError):
            if ino is None or os.stat(path).st_ino == ino:
                os.unlink(path)
        warn_once(("corrupt", path, reason), f"proleg cache: deleted the damaged entry {path} ({reason}); it is rebuilt.")

    # -- write ---------------------------------------------------------------------------------
    def write(self, kind: str, name: str, key: str, payload: bytes) -> bool:
        """Publish ``payload`` under ``key``: written to a temporary file in the same folder,
        fsync'ed, renamed over the entry (atomic: a reader sees the old entry or the new one,
        never a part). False when not written (caching off, larger than the cap, or an error:
        a full disk or read-only folder turns writing off with one warning)."""
        if not self.writable:
            return False
        cap = max_bytes()
        blob = encode(key, payload)
        if len(blob) > cap:
            return False
        path = self.path(kind, name)
        folder = os.path.dirname(path)
        tmp = os.path.join(folder, f".{name[:120]}.{os.getpid()}.{threading.get_ident()}.{secrets.token_hex(4)}.tmp")
        try:
            os.makedirs(folder, exist_ok=True)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o644)
            try:
                view = memoryview(blob)
                while view:
                    view = view[os.write(fd, view[: 1 << 20]) :]
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, path)
        except OSError as exc:
            stats["write_failed"] += 1
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            if exc.errno == errno.ENOENT and os.path.isdir(self.root):  # the folder emptied under us (cache clear)
                return False
            self.writable = False
            warn_once(("off", self.root), f"proleg cache: cannot write to {self.root} ({type(exc).__name__}: {exc}); "
                      "caching new compiled functions is off in this process, and the run goes on without it. Free disk "
                      "space or fix the folder's permissions, or set PROLEG_CACHE_DIR to a writable folder ('' turns the cache off).")
            return False
        stats["written"] += 1
        self._account(len(blob), path)
        return True

    # -- size cap ------------------------------------------------------------------------------
    def _account(self, nbytes: int, keep: str) -> None:
        """Enforce the cap after a write: scan the folder (O(files)) on this process's first write,
        when the bytes known may exceed the cap, and after every 1/16 of the cap written here (so
        that other processes' writes are counted too)."""
        cap = max_bytes()
        with self._lock:
            self._since_scan += nbytes
            if self._total is not None and self._total + self._since_scan <= cap and self._since_scan <= cap // 16:
                return
            self._total = self.evict(cap, keep=keep)
            self._since_scan = 0

    def files(self) -> list[tuple[float, int, str, str]]:
        """(mtime, size, path, kind) of every file the store owns: entries by kind, "tmp" for a
        write in progress, "legacy" for older formats; a killed writer's old temporary files are
        deleted on the way."""
        out = []
        now = time.time()
        for kind in (*KINDS, ""):
            folder = os.path.join(self.root, kind)
            try:
                it = os.scandir(folder)
            except OSError:
                continue
            with it:
                for e in it:
                    try:
                        if not e.is_file(follow_symlinks=False):
                            continue
                        st = e.stat(follow_symlinks=False)
                    except OSError:
                        continue
                    if _TMP.search(e.name) and kind:
                        if now - st.st_mtime > STALE_TMP_S:
                            with contextlib.suppress(OSError):
                                os.unlink(e.path)
                            continue
                        k = "tmp"
                    elif kind and e.name.endswith(SUFFIX):
                        k = kind
                    elif (kind == "export" and e.name.endswith(".pkl")) or (not kind and _JAX_LEGACY.search(e.name)):
                        k = "legacy"
                    else:
                        continue  # not ours: never counted, never deleted
                    out.append((st.st_mtime, st.st_size, e.path, k))
        return out

    def evict(self, cap: int, keep: str | None = None) -> int:
        """Delete least recently used files (older formats' first: no proleg reads them now) until
        the folder holds at most ``LOW_WATER × cap`` bytes if it holds more than ``cap``; returns
        the bytes left."""
        files = self.files()
        total = sum(f[1] for f in files)
        if total > cap:
            target = int(cap * LOW_WATER)
            for _mtime, size, path, kind in sorted(files, key=lambda f: (f[3] != "legacy", f[0])):  # older formats first
                if total <= target:
                    break
                if path == keep or kind == "tmp":
                    continue
                try:
                    os.unlink(path)
                except FileNotFoundError:
                    pass
                except OSError:
                    continue
                total -= size
                stats["evicted"] += 1
        return total

    def info(self) -> dict:
        """Folder, cap, and count and bytes of entries by kind (with "tmp" and "legacy")."""
        by: dict = {k: {"entries": 0, "bytes": 0} for k in (*KINDS, "tmp", "legacy")}
        for _m, size, _p, kind in self.files():
            by[kind]["entries"] += 1
            by[kind]["bytes"] += size
        return {"dir": self.root, "exists": os.path.isdir(self.root), "max_bytes": max_bytes(),
                "total_bytes": sum(v["bytes"] for v in by.values()), "kinds": by}

    def clear(self) -> int:
        """Delete every file the store owns (other files in the folder are left); returns how many."""
        n = 0
        for _m, _s, path, _k in self.files():
            with contextlib.suppress(OSError):
                os.unlink(path)
                n += 1
        for kind in KINDS:
            with contextlib.suppress(OSError):
                os.rmdir(os.path.join(self.root, kind))  # only if empty
        with self._lock:
            self._total, self._since_scan = None, 0
        return n


_STORES: dict[str, Store] = {}
_STORES_LOCK = threading.Lock()


def get(root: str) -> Store:
    """The :class:`Store` of folder ``root`` in this process."""
    root = os.path.abspath(os.path.expanduser(root))
    with _STORES_LOCK:
        st = _STORES.get(root)
        if st is None:
            st = _STORES[root] = Store(root)
        return st


# -- JAX's persistent compilation cache through this store ---------------------------------------
def _jax_cache_class():
    from jax._src.compilation_cache_interface import CacheInterface

    class XlaEntries(CacheInterface):
        """JAX's persistent compilation cache on :class:`Store` entries of kind ``xla``.

        JAX's own file cache (jax._src.lru_cache, JAX 0.10) writes entries in place, so a killed
        process leaves a truncated file; it checks nothing but zlib's Adler-32 (and with zstd,
        nothing); a damaged entry is warned about on every later run and never rewritten, since
        ``put`` skips a key whose file exists. Here an entry is verified before XLA deserialises
        it, a damaged one is deleted (one warning) and rewritten, and writes are atomic."""

        def __init__(self, path):
            import pathlib

            self._path = pathlib.Path(path)
            self.store = get(str(path))

        def get(self, key: str):
            try:
                return self.store.read("xla", entry_name(key), key)
            except Exception:  # never let the cache break a compile
                return None

        def put(self, key: str, value: bytes) -> None:
            with contextlib.suppress(Exception):
                self.store.write("xla", entry_name(key), key, bytes(value))

    return XlaEntries


def install_jax_cache(path: str) -> bool:
    """Route JAX's persistent compilation cache through this store and point it at ``path``
    (unless the user set ``jax_compilation_cache_dir``). Returns False, leaving JAX's
    persistent cache off, where this JAX does not have the hook (``get_file_cache``): its own
    store cannot promise the guarantees above, and proleg's ``export`` entries still work."""
    import jax

    try:
        from jax._src import compilation_cache as jcc

        original = jcc.get_file_cache
        cls = _jax_cache_class()
    except (ImportError, AttributeError):
        return False
    if not getattr(original, "_proleg", False):

        def get_file_cache(p):
            p = str(p)
            if "://" in p and not p.startswith("file://"):  # a remote file system: JAX's own
                return original(p)
            return cls(p.removeprefix("file://")), p

        get_file_cache._proleg = True
        get_file_cache._original = original
        jcc.get_file_cache = get_file_cache
    with contextlib.suppress(OSError):  # an uncreatable folder is reported at the first write
        os.makedirs(path, exist_ok=True)
    try:
        if jax.config.jax_compilation_cache_dir is None:
            jax.config.update("jax_compilation_cache_dir", path)
            # every executable, also those compiled in under 0.1 s at the "once" XLA options (a warm
            # start loads them: README example 1.24 -> 1.18 s, bench/compile_cache.py --table)
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
            jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    except AttributeError:  # an older jax
        return False
    return True
