"""What every command writes by: output checks, atomic writes, provenance.

* :func:`check_output` / :func:`check_free`: before anything is computed, the
  output directory can be written and no output is there already (unless
  ``--overwrite``); a :class:`~jaxwalk.errors.ConfigError` otherwise, so bad
  input costs no computation and leaves nothing half-written.
* :func:`write_atomically` (a file) and :func:`write_zarr` (a zarr store): written
  under a hidden temporary directory beside the target and renamed into place,
  so a reader never sees half an output and a failure leaves nothing behind.
* :func:`provenance`: the attributes every dataset carries (when, by which
  command, with which package versions and which jaxwalk source,
  :func:`source_digest`).
"""

from __future__ import annotations

import datetime as _dt
import functools
import hashlib
import importlib.metadata
import inspect
import os
import platform
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any, Callable, Iterable

from jaxwalk.errors import ConfigError

#: Packages whose versions every dataset records (``<name>_version`` attributes).
VERSIONED = ("jax", "jaxlib", "diffrax", "equinox", "optimistix", "numpy", "xarray", "zarr")
#: jaxwalk's own source directory.
PACKAGE = Path(__file__).resolve().parent


# ---------------------------------------------------------------- source


@functools.lru_cache(maxsize=None)
def file_digest(path: str) -> str:
    """SHA-256 of a file's bytes (hex), once per process."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 (hex) of jaxwalk's own Python source, every file by its path and
    bytes: which code made a result, where the version number (bumped by hand)
    does not change with every edit."""
    h = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*.py")):
        h.update(f"{path.relative_to(PACKAGE)}:{file_digest(str(path))}\n".encode())
    return h.hexdigest()


def model_sources(model_class) -> list[str]:
    """Source files of the model's classes outside jaxwalk (a user's or a test's model)."""
    files = set()
    for cls in model_class.__mro__:
        try:
            path = inspect.getsourcefile(cls)
        except TypeError:  # builtins
            continue
        if path and not Path(path).resolve().is_relative_to(PACKAGE):
            files.add(str(Path(path).resolve()))
    return sorted(files)


# ---------------------------------------------------------------- checks


def check_output(out_dir: str | os.PathLike, name: str, *, overwrite: bool = False,
                 others: Iterable[Path] = ()) -> Path:
    """``out_dir/<name>.zarr`` if it, and the files ``others``, can be written; creates nothing.

    Raises:
        ConfigError: ``out_dir`` is not a directory or not writable, or an output
            exists and ``overwrite`` is false.
    """
    if not str(out_dir).strip():
        raise ConfigError("--out is empty: name a directory ('.' for this one)")
    out = Path(out_dir)
    target = out / f"{name}.zarr"
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out '{out}' exists and is not a directory")
    existing = out
    while not existing.exists():  # the nearest existing ancestor is the one that must be writable
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(f"--out '{out}': '{existing}' is not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"--out '{out}': '{existing}' is not writable")
    for path in (target, *others):
        check_free(path, overwrite=overwrite)
    return target


def check_file(path: str | os.PathLike, option: str, *, overwrite: bool = False) -> Path:
    """``path`` if a file can be written there (``option`` names it in the message):
    its directory exists and is writable, and nothing is there (unless ``overwrite``;
    a directory never). Creates nothing."""
    path = Path(path)
    parent = path.parent
    if path.is_dir():
        raise ConfigError(f"{option} '{path}' is a directory")
    if not parent.is_dir():
        raise ConfigError(f"{option} '{path}': '{parent}' is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{option} '{path}': '{parent}' is not writable")
    return check_free(path, overwrite=overwrite)


def check_free(path: Path, *, overwrite: bool = False) -> Path:
    """``path`` if nothing is there (a dangling link counts as something) or ``overwrite``."""
    if (path.exists() or path.is_symlink()) and not overwrite:
        raise ConfigError(f"'{path}' already exists (pass --overwrite to replace it)")
    return path


# ---------------------------------------------------------------- atomic writes


def write_atomically(target: str | os.PathLike, write: Callable[[Path], Any]) -> Path:
    """``write(path)`` into a hidden directory beside ``target``, then rename it into place.

    The file gets the permissions a plain ``open()`` gives under the user's umask
    (it is created inside a private directory, not as a private file).
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        path = tmp / target.name
        write(path)
        os.replace(path, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return target


def write_zarr(ds, target: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write the :class:`xarray.Dataset` ``ds`` to the zarr v3 store ``target``
    (consolidated metadata), atomically; an existing ``target`` is replaced only with ``overwrite``.

    Raises:
        FileExistsError: ``target`` exists and ``overwrite`` is false.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        store = tmp / target.name
        with warnings.catch_warnings():
            # Consolidated metadata is a zarr-python extension to the v3 spec; xarray
            # reads it, and without it every open warns and lists the store.
            warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part")
            ds.to_zarr(store, mode="w-", zarr_format=3, consolidated=True)
        if target.exists() or target.is_symlink():
            if not overwrite:
                raise FileExistsError(f"'{target}' already exists")
            old = tmp / "replaced"
            os.rename(target, old)
            try:
                os.rename(store, target)
            except BaseException:
                os.rename(old, target)  # the old store back: a failed replace loses nothing
                raise
        else:
            os.rename(store, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return target


# ---------------------------------------------------------------- provenance


def package_versions() -> dict[str, str]:
    """``{"jaxwalk": ..., "jax": ..., ..., "python": ...}`` without importing the packages."""
    from jaxwalk import __version__  # here: the package's __init__ may be importing this module

    out = {"jaxwalk": __version__}
    for name in VERSIONED:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    out["python"] = platform.python_version()
    return out


def provenance(command: str | None, program: str, *, created: _dt.datetime | None = None,
               extra_versions: Iterable[str] = ()) -> dict[str, str]:
    """The attributes that say how a dataset was made.

    ``created`` (ISO 8601, UTC, seconds; default now), ``command`` (the command
    line, ``""`` from Python), ``history`` (``"<created>: <command or program>"``,
    ``program`` naming the Python entry point), ``<package>_version`` for
    :data:`VERSIONED` and ``extra_versions``, and ``jaxwalk_source_sha256``
    (:func:`source_digest`).
    """
    created_s = (created or _dt.datetime.now(_dt.timezone.utc)).isoformat(timespec="seconds")
    versions = package_versions()
    for name in extra_versions:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return {
        "created": created_s,
        "command": command or "",
        "history": f"{created_s}: {command or program}",
        **{f"{name}_version": v for name, v in versions.items()},
        "jaxwalk_source_sha256": source_digest(),
    }
