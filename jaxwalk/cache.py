"""Where jaxwalk keeps the programs it compiled and traced, so reruns skip both.

Two caches share one directory:

- compiled programs (XLA executables): JAX's persistent compilation cache,
  its files (``<key>-cache``, ``<key>-atime``) directly in the directory;
- traced programs (StableHLO, :mod:`jaxwalk.program_cache`), in its
  ``jaxwalk-programs/`` subdirectory.

The directory is, first found: the ``directory`` given to :func:`configure`
(the command line's ``--cache-dir``), ``$JAXWALK_CACHE_DIR``,
``$JAX_COMPILATION_CACHE_DIR`` (a user who already keeps JAX's cache
somewhere keeps it there), ``$XDG_CACHE_HOME/jaxwalk``, ``~/.cache/jaxwalk``.
``JAXWALK_CACHE_DIR`` set to the empty string, ``--no-cache`` or
``configure(enabled=False)`` switch both caches off.

``import jaxwalk`` calls :func:`configure` with those defaults; it sets JAX's
global options ``jax_compilation_cache_dir`` and
``jax_persistent_cache_min_compile_time_secs = 0`` (every program is kept, so a
rerun compiles nothing at all). A directory that cannot be created or written
costs one warning and a compile: the caches are then off, never an error. A
disk that fills up later costs JAX's own warning and, for traced programs,
the next run's trace.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import jax
from jax.experimental.compilation_cache import compilation_cache as _jax_cache

ENV = "JAXWALK_CACHE_DIR"
#: Subdirectory of traced programs (:mod:`jaxwalk.program_cache`).
PROGRAMS = "jaxwalk-programs"
#: Suffixes of JAX's compilation cache files (jax/_src/lru_cache.py).
_JAX_SUFFIXES = ("-cache", "-atime")

_state: dict = {"root": None}


class CacheWarning(UserWarning):
    """The cache directory cannot be used: programs are compiled afresh."""


def default_directory() -> Path | None:
    """The directory the environment asks for, or ``None`` when it switches the caches off."""
    if ENV in os.environ:
        value = os.environ[ENV]
        return Path(value).expanduser() if value else None
    if os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return Path(os.environ["JAX_COMPILATION_CACHE_DIR"]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "jaxwalk"


def configure(directory: str | os.PathLike | None = None, *, enabled: bool = True, warn: bool = True) -> Path | None:
    """Point both caches at ``directory`` (default :func:`default_directory`),
    or switch them off; return the directory in use, ``None`` when off.

    An unusable directory switches the caches off with a :class:`CacheWarning`,
    now or (``warn=False``, as ``import jaxwalk`` does, so that the command line
    can word it as its other messages) at the next :func:`report`. The choice is
    also written to ``$JAXWALK_CACHE_DIR`` so that processes started from this
    one (Dask workers) use the same directory.
    """
    root = (Path(directory).expanduser() if directory is not None else default_directory()) if enabled else None
    _state["problem"] = None
    if root is not None:
        problem = _unwritable(root)
        if problem:
            _state["problem"] = (
                f"cache directory '{root}' cannot be used ({problem}); programs are compiled afresh "
                f"(--cache-dir DIR or {ENV}=DIR to move it, --no-cache to silence this)"
            )
            root = None
    if root != _state["root"]:
        _jax_cache.reset_cache()  # JAX opens its cache once, at the first compile: let it reopen
    _state["root"] = root
    jax.config.update("jax_enable_compilation_cache", root is not None)
    jax.config.update("jax_compilation_cache_dir", None if root is None else str(root))
    # Keep every program: the small ones add up to seconds per run, and "a rerun
    # compiles nothing" is then true without exceptions.
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    if root is not None or not enabled:  # an unusable directory stays the choice, for the message
        os.environ[ENV] = "" if root is None else str(root)
    if warn:
        report()
    return root


def report() -> None:
    """Warn (:class:`CacheWarning`, once) if the configured directory could not be used."""
    problem = _state.get("problem")
    if problem:
        _state["problem"] = None
        warnings.warn(problem, CacheWarning, stacklevel=3)


def directory() -> Path | None:
    """The cache directory in use, ``None`` when the caches are off."""
    return _state["root"]


def unusable(root: str | os.PathLike) -> str | None:
    """Why ``root`` cannot hold the caches, or ``None`` if it can (tried by writing a file;
    the directory is created if it is missing)."""
    return _unwritable(Path(root).expanduser())


def _unwritable(root: Path) -> str | None:
    """Why ``root`` cannot hold the caches, or ``None`` if it can (tried by writing a file)."""
    try:
        root.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=root, prefix=".probe-")
        os.close(fd)
        os.remove(probe)
    except OSError as err:
        return err.strerror or str(err)
    return None


@dataclass(frozen=True)
class CacheInfo:
    """What a cache directory holds: files and bytes of compiled and of traced programs."""

    directory: Path | None
    compiled_files: int
    compiled_bytes: int
    traced_files: int
    traced_bytes: int


def _compiled(root: Path) -> list[Path]:
    return [p for p in root.iterdir() if p.is_file() and p.name.endswith(_JAX_SUFFIXES)] if root.is_dir() else []


def _traced(root: Path) -> list[Path]:
    programs = root / PROGRAMS
    return [p for p in programs.iterdir() if p.is_file()] if programs.is_dir() else []


def info(root: str | os.PathLike | None = None) -> CacheInfo:
    """What ``root`` (default: the directory in use) holds."""
    root = Path(root) if root is not None else directory()
    if root is None:
        return CacheInfo(None, 0, 0, 0, 0)
    compiled, traced = _compiled(root), _traced(root)
    return CacheInfo(
        root, len(compiled), sum(p.stat().st_size for p in compiled), len(traced), sum(p.stat().st_size for p in traced)
    )


def clear(root: str | os.PathLike | None = None) -> CacheInfo:
    """Delete the cached programs in ``root`` (default: the directory in use); return what was there.

    Only JAX's cache files and ``jaxwalk-programs/`` are removed, so a cache
    directory pointed at a directory holding other things loses nothing else.
    """
    before = info(root)
    if before.directory is None:
        return before
    for path in _compiled(before.directory):
        path.unlink(missing_ok=True)
    shutil.rmtree(before.directory / PROGRAMS, ignore_errors=True)
    return before
