"""A sweep's dataset written chunk by chunk as the chunks finish, resumable after a kill.

The grid is cut into blocks (:func:`jaxwalk.grid.chunk_shape`: ``chunk_size``
points, whole continuation lines), which are also the zarr chunks of every
grid variable, so each finished block is one write per variable and no two
blocks share a file. While a sweep runs, its output directory holds::

    DIR/.<name>.zarr.partial/      the run in progress
        run.json                   what it computes: the fingerprint (resolved config,
                                   analysis options, chunk shape, package versions)
        <name>.zarr/               the dataset: every array created at full size,
                                   filled block by block
        done/<i>                   one empty file per block whose data are written,
                                   created only after they are

When every block is done the store's metadata are consolidated and it is
renamed to ``DIR/<name>.zarr``; then the partial directory goes. A run killed at
any moment leaves either nothing, or a partial directory that the same command
continues (only blocks without their ``done`` file are computed again, and
rewriting one gives the same bits), or the finished dataset. Every step is a
rename or a new file: the partial directory appears whole (its template is built
in a temporary directory first), zarr writes each chunk file to a temporary
name and renames it, and ``done/<i>`` is created after its block's writes
return. Survives a killed process, not a lost machine: nothing is fsynced.

Memory stays flat: the template's arrays are zero-stride views, and a block's
results are the only numbers held at any time.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import json
import os
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np

from jaxwalk import analyses
from jaxwalk.configs import human_bytes
from jaxwalk.errors import ConfigError
from jaxwalk.status import Status
from jaxwalk.sweep.config import GridAxis, SweepConfig
from jaxwalk.walker import Walker

PARTIAL_SUFFIX = ".partial"
RUN_FILE = "run.json"
DONE_DIR = "done"
#: Packages whose versions can change the numbers: a partial run is continued only with the same ones.
NUMERIC_PACKAGES = ("jaxwalk", "jax", "jaxlib", "diffrax", "equinox", "optimistix", "numpy")
#: Metadata of a zarr array or group (zarr.json), bytes, for the disk estimate.
_METADATA_BYTES = 4096


def partial_path(target: Path) -> Path:
    """``DIR/.<name>.zarr.partial`` for ``target = DIR/<name>.zarr``."""
    return target.parent / f".{target.name}{PARTIAL_SUFFIX}"


@dataclasses.dataclass
class ChunkStore:
    """The streamed dataset of one sweep: where it goes, its blocks, which are done.

    Made by :meth:`plan`, which checks everything and writes nothing; the first
    :meth:`write` creates the partial directory (a run that fails before its
    first block is done leaves nothing behind), :meth:`finish` puts the dataset
    in place.

    Attributes:
        target: the finished dataset's path, ``DIR/<name>.zarr``.
        partial: the run in progress, ``DIR/.<name>.zarr.partial``.
        shape: the grid's shape ``S``.
        chunks: the blocks' shape (:func:`jaxwalk.grid.chunk_shape`).
        n_chunks: number of blocks, numbered in C order of the block grid.
        done: the blocks already written (by an earlier run of the same sweep, or this one).
    """

    config: SweepConfig
    model: Walker
    target: Path
    shape: tuple[int, ...]
    chunks: tuple[int, ...]
    n_chunks: int
    fingerprint: dict[str, str]
    command: str
    options: Mapping
    overwrite: bool
    done: set[int]
    _group: object = None

    @property
    def partial(self) -> Path:
        return partial_path(self.target)

    @property
    def store(self) -> Path:
        return self.partial / self.target.name

    # ---------------------------------------------------------------- planning

    @classmethod
    def plan(
        cls,
        config: SweepConfig,
        model: Walker,
        target: Path,
        *,
        chunk_size: int,
        options: Mapping,
        command: str = "",
        overwrite: bool = False,
    ) -> "ChunkStore":
        """Lay out the store and check it can be written; writes nothing.

        Args:
            config, model: the sweep.
            target: ``DIR/<name>.zarr`` (already checked by ``runner.check_output``).
            chunk_size: points per block (``AnalysisOptions.chunk_size``).
            options: every analysis setting, JSON-able (recorded, and part of the fingerprint).
            command: the command line, recorded in the dataset.
            overwrite: a partial run of a different sweep is discarded instead of refused.

        Raises:
            ConfigError: a partial run of a different sweep is there (without
                ``overwrite``), or the dataset would not fit on the disk.
        """
        from jaxwalk.grid import chunk_count, chunk_shape
        from jaxwalk.files import file_digest, model_sources, package_versions, source_digest

        shape = config.shape
        along = None if config.continuation is None else config.dims.index(config.continuation)
        chunks = chunk_shape(shape, chunk_size, along)
        n_chunks = int(np.prod(chunk_count(shape, chunks), dtype=np.int64))
        versions = package_versions()
        parts = {
            "config": config.to_dict(),
            "analysis options": options,
            "chunk shape (--chunk-size)": list(chunks),
            "package versions": {k: versions.get(k, "") for k in NUMERIC_PACKAGES},
            # The code itself: an edit between a killed run and its rerun must not mix two codes' results.
            "jaxwalk source": [source_digest()] + [f"{p}:{file_digest(p)}" for p in model_sources(type(model))],
        }
        fingerprint = {k: hashlib.sha256(json.dumps(v, sort_keys=True, default=str).encode()).hexdigest() for k, v in parts.items()}
        self = cls(
            config, model, Path(target), shape, chunks, n_chunks, fingerprint, command, dict(options), overwrite, set(),
        )
        self._check_partial()
        self._check_disk()
        return self

    def _check_partial(self) -> None:
        partial = self.partial
        if not partial.exists():
            return
        recorded = json_fingerprint(partial)
        if recorded is None or not self.store.is_dir():
            # Not a run we can continue: the leftover of one that finished (killed
            # after the rename) or was broken by hand. Ours to discard.
            self.done = set()
            return
        if recorded == self.fingerprint:
            self.done = self._read_done()
            return
        if self.overwrite:
            return  # discarded when this run writes its first block
        differ = [k for k in self.fingerprint if recorded.get(k) != self.fingerprint[k]]
        how = ("jaxwalk's code has changed since it started: run it with that code to continue it"
               if differ == ["jaxwalk source"] else "rerun the command that started it to continue it")
        raise ConfigError(
            f"'{partial}' holds an unfinished run of a different sweep ({', '.join(differ)} differ); "
            f"{how}, or pass --overwrite to discard it and start over"
        )

    def _read_done(self) -> set[int]:
        try:
            names = os.listdir(self.partial / DONE_DIR)
        except FileNotFoundError:
            return set()
        return {int(n) for n in names if n.isdigit() and int(n) < self.n_chunks}

    def _variable_layout(self):
        """The template dataset (zero-stride views of each output's fill value,
        :func:`jaxwalk.analyses.template`) and each data variable's chunk shape."""
        from jaxwalk.sweep.dataset import build_dataset

        template = analyses.template(self.config, len(self.model.section_names))
        ds = build_dataset(self.config, self.model, template, command=self.command, options=self.options)
        chunks = {name: self.chunks + var.shape[len(self.shape) :] for name, var in ds.data_vars.items()}
        return ds, chunks

    def estimated_bytes(self, n_chunks: int | None = None, block: int = 4096) -> int:
        """Disk space of ``n_chunks`` blocks (default all), uncompressed: an upper
        bound, each chunk file rounded up to the file system's ``block`` size."""
        n_chunks = self.n_chunks if n_chunks is None else n_chunks
        ds, chunks = self._variable_layout()
        total = _METADATA_BYTES * (1 + len(ds.variables))
        total += sum(int(np.prod(ds[c].shape)) * ds[c].dtype.itemsize for c in ds.coords)
        for name, var in ds.data_vars.items():
            file_bytes = int(np.prod(chunks[name], dtype=np.int64)) * var.dtype.itemsize
            total += n_chunks * (-(-file_bytes // block) * block)
        return total

    def _check_disk(self) -> None:
        existing = self.target.parent
        while not existing.exists() and existing.parent != existing:
            existing = existing.parent
        try:
            block = os.statvfs(existing).f_frsize or 4096
        except (AttributeError, OSError):
            block = 4096
        remaining = self.n_chunks - len(self.done)
        need = self.estimated_bytes(remaining, block)
        free = shutil.disk_usage(existing).free
        if need > free:
            raise ConfigError(
                f"the dataset needs up to {human_bytes(need)} on disk ({remaining:,} chunk{'s' * (remaining != 1)} of "
                f"{' x '.join(map(str, self.chunks))} points, uncompressed) but '{os.path.abspath(existing)}' has "
                f"{human_bytes(free)} free (free some space, shrink the grid, or write elsewhere with --out)"
            )

    # ---------------------------------------------------------------- running

    @property
    def points_done(self) -> int:
        return sum(self.points_in(i) for i in self.done)

    def points_in(self, index: int) -> int:
        return int(np.prod([r.stop - r.start for r in self.region(index)]))

    def region(self, index: int) -> tuple[slice, ...]:
        from jaxwalk.grid import chunk_region

        return chunk_region(self.shape, self.chunks, index)

    def pending(self) -> Iterator[int]:
        """Blocks still to compute, in order (lazily: no list of the grid's blocks)."""
        return (i for i in range(self.n_chunks) if i not in self.done)

    def write(self, index: int, results: Mapping[str, np.ndarray]) -> None:
        """Write block ``index``'s checked results (``runner.check_results``, of the
        block's shape), then mark it done."""
        from jaxwalk.sweep.dataset import build_dataset

        group = self._open()
        region = self.region(index)
        axes = tuple(GridAxis(a.name, a.values[r], a.spec) for a, r in zip(self.config.axes, region))
        # build_dataset lays the block out exactly as the whole dataset (variable names, dtypes).
        ds = build_dataset(dataclasses.replace(self.config, axes=axes), self.model, results, options=self.options)
        for name, var in ds.data_vars.items():
            group[name][region] = var.values
        (self.partial / DONE_DIR / str(index)).touch()
        self.done.add(index)

    def _open(self):
        import zarr

        if self._group is None:
            if not self.store.is_dir() or json_fingerprint(self.partial) != self.fingerprint:
                self._create()
            else:
                self._note_resume()
            self._group = zarr.open_group(self.store, mode="r+", zarr_format=3)
        return self._group

    def _create(self) -> None:
        """Build the empty store and ``run.json`` in a temporary directory, then rename it into place."""
        import zarr

        parent = self.target.parent
        parent.mkdir(parents=True, exist_ok=True)
        for stale in parent.glob(f".{self.target.name}{PARTIAL_SUFFIX}.*.tmp"):  # a kill while building one
            shutil.rmtree(stale, ignore_errors=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{self.target.name}{PARTIAL_SUFFIX}.", suffix=".tmp", dir=parent))
        try:
            ds, chunks = self._variable_layout()
            store = tmp / self.target.name
            # Coordinates and global attributes as xarray writes them...
            ds.drop_vars(list(ds.data_vars)).to_zarr(store, mode="w-", zarr_format=3, consolidated=False)
            # ...and each data variable with xarray's encoding (fill value, _FillValue,
            # codecs), read off a one-point copy, created at full size without data.
            mini = ds[list(ds.data_vars)].isel({d: slice(0, 1) for d in self.config.dims})
            memory = zarr.storage.MemoryStore()
            mini.to_zarr(memory, mode="w-", zarr_format=3, consolidated=False)
            source = zarr.open_group(memory, mode="r")
            group = zarr.open_group(store, mode="r+", zarr_format=3)
            # Statuses are NOT_COMPUTED where never written: an unwritten chunk never reads as "ok".
            statuses = {o.name for o in analyses.outputs(analyses.active(self.config)) if o.flags}
            for name, var in ds.data_vars.items():
                src = source[name]
                zarr.create_array(
                    group.store, name=name, shape=var.shape, chunks=chunks[name], dtype=src.dtype,
                    fill_value=np.int8(Status.NOT_COMPUTED) if name in statuses else src.fill_value,
                    attributes=dict(src.attrs), dimension_names=src.metadata.dimension_names,
                    compressors=src.compressors, serializer=src.serializer, filters=src.filters,
                )
            (tmp / DONE_DIR).mkdir()
            record = {"fingerprint": self.fingerprint, "config": self.config.to_dict(), "chunks": list(self.chunks),
                      "n_chunks": self.n_chunks, "command": self.command}
            (tmp / RUN_FILE).write_text(json.dumps(record, indent=1))
            if self.partial.exists():  # a different sweep's, discarded under --overwrite, or a leftover
                shutil.rmtree(self.partial)
            os.rename(tmp, self.partial)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        self.done = set()

    def _note_resume(self) -> None:
        import zarr

        group = zarr.open_group(self.store, mode="r+", zarr_format=3)
        now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        history = group.attrs.get("history", "")
        group.attrs["history"] = f"{history}\n{now}: continued ({len(self.done)} of {self.n_chunks} chunks were done): {self.command}"

    def set_attributes(self, attrs: Mapping[str, str]) -> None:
        """Set global attributes of the dataset (e.g. the seed lines' results:
        computed again, the same, by a resumed run)."""
        if attrs:
            self._open().attrs.update(dict(attrs))

    def finish(self) -> Path:
        """Consolidate the metadata and move the finished dataset to ``target``."""
        import zarr

        missing = self.n_chunks - len(self.done)
        if missing:
            raise RuntimeError(f"{missing} of {self.n_chunks} chunks not written")
        if self._group is None:  # every block was done already: only the rename was left
            self._open()
        for junk in self.store.rglob(f"*{PARTIAL_SUFFIX}"):  # zarr's temporaries of a write a kill cut short
            junk.unlink()
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part")
            zarr.consolidate_metadata(self.store, zarr_format=3)
        if self.target.exists() or self.target.is_symlink():
            if not self.overwrite:
                raise FileExistsError(f"'{self.target}' already exists")
            os.rename(self.target, self.partial / "replaced")
        os.rename(self.store, self.target)
        shutil.rmtree(self.partial, ignore_errors=True)
        return self.target


def json_fingerprint(partial: Path) -> dict | None:
    """The fingerprint recorded in a partial run's ``run.json`` (``None`` if unreadable)."""
    try:
        return json.loads((partial / RUN_FILE).read_text())["fingerprint"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
