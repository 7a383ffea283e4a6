"""What an analysis beside the gait declares: its config keys, its outputs, its program.

A plug-in is one module of :mod:`jaxwalk.analyses` holding ``ANALYSIS``, an
instance of a subclass of :class:`Analysis`, and the declared shape of its
settings (a :class:`~jaxwalk.configs.Table`: its keys, their types, ranges,
defaults and messages, written once). Everything a sweep does with it
goes through these methods: the config parser (:meth:`parse`,
:meth:`to_dict`), the grid (:meth:`grid_options`, :meth:`compute`), the
runner's checks (:meth:`finalise`), the store and the dataset
(:meth:`outputs`, :meth:`sizes`, :meth:`variables`) and, for analyses of the
whole grid, the end of a run (:meth:`finish`).

Plug-in modules import nothing heavy at module level (a config is checked
without JAX) and never import :mod:`jaxwalk.grid` or :mod:`jaxwalk.sweep`
(those import the registry).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Mapping, NamedTuple

import numpy as np

from jaxwalk import outputs as schema
from jaxwalk.configs import Table, did_you_mean as did_you_mean  # where plug-ins found it
from jaxwalk.outputs import Output


def switch(table: Mapping[str, Any], key: str, settings: type[Table], fail, example: str, *,
           true_is_defaults: bool = True, **context: Any) -> Table | None:
    """``[analysis] <key>`` written as ``false``/absent (``None``: off), ``true`` (the
    ``settings`` Table's defaults; refused where ``true_is_defaults`` is false: a
    key without a default) or a table checked as ``settings`` (``example``: its
    form in the error message, ``"{ step = .., count = .. }"``; ``context``: the words
    of the Table's messages, :meth:`~jaxwalk.configs.Table.check`)."""
    where = f"[analysis] {key}"
    value = table.get(key, False)
    if value is False:
        return None
    if not isinstance(value, Mapping) and not (value is True and true_is_defaults):
        forms = "true, false" if true_is_defaults else "false"
        raise fail(f"{where} must be {forms} or a table {example}, got {value!r}")
    return settings.check({} if value is True else value, fail, where=where, **context)


@dataclasses.dataclass(frozen=True)
class Block:
    """What a grid block's analyses start from (:func:`jaxwalk.grid.analyse_chunk`).

    Attributes:
        model: the walker.
        params: every parameter as an array of the block's shape ``S``.
        gaits: the block's :class:`jaxwalk.gait.Gait` (leaves ``S + ...``).
        results: the outputs so far (the gait's, then each earlier analysis's), ``S + ...``.
        options: the :class:`jaxwalk.grid.AnalysisOptions`.
        sub_batch: configurations advanced together in one ``lax.map`` step
            (:func:`jaxwalk.grid.sub_batch_size`).
        run: ``run(program, rows)``: a jitted program over flat rows, in chunks on
            every worker thread (:func:`jaxwalk.batching.run_chunks` with the block's chunk size).
    """

    model: Any
    params: Mapping[str, np.ndarray]
    gaits: Any
    results: Mapping[str, np.ndarray]
    options: Any
    sub_batch: int
    run: Callable

    @property
    def shape(self) -> tuple[int, ...]:
        return self.results["status"].shape

    def rows_at_gaits(self):
        """One :class:`~jaxwalk.batching.Rows` row per grid point: every parameter,
        and as inputs :class:`AtGait`, its fixed point (NaN where there is no gait)."""
        from jaxwalk.batching import Rows

        v = np.asarray(self.gaits.v)
        return Rows({k: np.asarray(x).reshape(-1) for k, x in self.params.items()}, AtGait(v.reshape(-1, v.shape[-1])))


def run_with_bar(block: Block, program, rows, desc: str, unit: str, sub_batch: int = 1, per_call: int = 1):
    """``block.run(program, rows)`` in calls of ``per_call`` sub-batches of ``sub_batch``
    rows per worker thread, under a :func:`jaxwalk.progress.stage` bar
    (``"<desc>, N <unit>s"``, with the time left): an analysis whose rows take
    seconds each (a flat-foot gait's step-down search or basin) would otherwise
    leave the sweep's bar standing still for many minutes. Each call waits for
    its slowest thread, so rows of very uneven cost want ``per_call`` above 1.

    With ``sub_batch`` the program's, each row meets the same lockstep partners
    as in one call of all of them (every ``n``-th row to thread ``i``,
    consecutive sub-batches, padded sub-batches skipped), and so the same
    result bit for bit, wherever the rows fit one chunk of ``block.run`` (a
    block of the default 256 points does) or that chunk is a multiple of a
    call's rows; with sub-batches of one (the basin's one gait per row, the
    flat-foot walker's nested engine) always. Elsewhere (a longer chunk than
    the default cut at another multiple) partners change, and results with
    them at the level of the integration noise."""
    import jax

    from jaxwalk.progress import stage
    from jaxwalk.workers import thread_count

    n = len(jax.tree_util.tree_leaves(rows)[0])
    group = thread_count() * sub_batch * per_call
    parts = []
    with stage(f"{desc}, {n} {unit}s", n, unit) as advance:
        for first in range(0, n, group):
            part = jax.tree_util.tree_map(lambda x, first=first: np.asarray(x)[first : first + group], rows)
            parts.append(block.run(program, part))
            advance(min(group, n - first))
    return jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *parts)


class AtGait(NamedTuple):
    """A program's input beside the parameters: the row's gait (:meth:`Block.rows_at_gaits`)."""

    v_star: Any  # (n, n_v) fixed point on the section; NaN where there is no gait


def row_program(one: Callable, sub_batch: int, kind: str, model, *settings):
    """``jit``: :class:`~jaxwalk.batching.Rows` -> ``one(params, inputs)`` for every row,
    ``sub_batch`` rows advancing together (:func:`jaxwalk.batching.over_rows`), named
    for the disk cache (:func:`jaxwalk.program_cache.register`: ``kind``, the model,
    the settings it closes over), compiled with the model's options
    (:mod:`jaxwalk.compiling`): a top-level program, not to be traced inside
    another ``jit``."""
    from jaxwalk import compiling, program_cache
    from jaxwalk.batching import over_rows

    program = compiling.jit(over_rows(one, sub_batch), model)
    program_cache.register(program, kind, model, *settings)
    return program


class Analysis:
    """An analysis beside the gait (subclass it; override what differs).

    Attributes:
        name: its name in the resolved config (``config.analyses``) and in
            :class:`jaxwalk.grid.AnalysisOptions`.
        keys: the ``[analysis]`` keys it reads.
        order: where it runs and is written among the analyses (ascending).
        off: its setting when it is off (``config.<name>`` then).
        options_field: the ``AnalysisOptions`` field holding its grid options;
            ``None``: they go in ``AnalysisOptions.more`` under :attr:`name` (and
            are recorded in a dataset only when the analysis is on).
        status_of_outputs: the status variable at whose ``OK`` points its
            ``finite_where_ok`` outputs must be finite.
        whole_grid: it runs once after every block is written (:meth:`finish`).
    """

    name: str = ""
    keys: tuple[str, ...] = ()
    order: int = 100
    off: Any = None
    options_field: str | None = None
    status_of_outputs: str = "status"
    whole_grid: bool = False

    # ------------------------------------------------------------ config

    def parse(self, table: Mapping[str, Any], fail, *, continuation: str | None) -> Any:
        """The resolved setting from ``[analysis]`` (JSON-ready), or :attr:`off`.
        ``fail(message)`` returns the exception to raise."""
        raise NotImplementedError

    def to_dict(self, resolved: Any) -> dict[str, Any]:
        """Its entries in the resolved config's ``[analysis]`` table (itself a valid config)."""
        return {} if resolved == self.off else {self.name: resolved}

    def fullest(self) -> Any:
        """A setting under which :meth:`outputs` lists every output it can write (plots, docs)."""
        return True

    def key_of(self, output: str) -> str:
        """The ``[analysis]`` key that switches on the output named ``output`` (what
        :func:`jaxwalk.walker.check_supported` reads the capability it needs under)."""
        return self.keys[0] if self.keys else self.name

    def check_model(self, resolved: Any, model, fail) -> None:
        """Refuse a model the analysis cannot run on (``fail(message)``); default: any."""

    def for_model(self, resolved: Any, model) -> Any:
        """The checked setting with what ``model`` decides filled in (the resolved
        config says every value the run uses); default: as it is."""
        return resolved

    # ------------------------------------------------------------ the grid

    def grid_options(self, resolved: Any) -> Any:
        """What :meth:`compute` needs of the settings (hashable), or ``None`` when off."""
        return None if resolved == self.off else resolved

    def options_of(self, options) -> Any:
        """Its grid options in an ``AnalysisOptions`` (``None``: not asked for)."""
        if self.options_field is not None:
            return getattr(options, self.options_field)
        return dict(options.more).get(self.name)

    def compute(self, block: Block) -> dict[str, np.ndarray]:
        """Its outputs on a block whose gaits are known: arrays of ``S`` plus their trailing shape."""
        return {}

    # ------------------------------------------------------------ results

    def outputs(self, resolved: Any) -> tuple[Output, ...]:
        """Its per-point outputs with these settings."""
        return ()

    def sizes(self, resolved: Any, n_v: int) -> dict[str, int]:
        """Sizes of the outputs' trailing axes."""
        return {"section": n_v, "eigen": n_v}

    def finalise(self, arrays: Mapping[str, np.ndarray], status: np.ndarray, resolved: Any) -> dict[str, np.ndarray]:
        """Its checked outputs, given every output's checked arrays (:func:`jaxwalk.outputs.take`)
        and the gait's final ``status``: by default every number is missing where
        there is no gait."""
        return schema.blank(arrays, self.outputs(resolved), status != 0)

    def variables(self, dims: tuple[str, ...], results: Mapping[str, np.ndarray], resolved: Any,
                  units: Mapping[str, str], model=None) -> dict[str, tuple]:
        """Its dataset variables (``{name: (dims, values, attrs)}``); ``model``: the
        walker, for attributes that name its parts (``None``: not known)."""
        return schema.variables(self.outputs(resolved), dims, results, resolved, units)

    def gradient(self, quantity: str, model, names: tuple[str, ...], solver, newton) -> Callable:
        """``(params, v0) -> (value, d value / d names)`` of one of its ``differentiable``
        outputs at one configuration (``v0``: a start for the gait search), for
        :mod:`jaxwalk.optimize`."""
        raise NotImplementedError(f"{self.name} declares no gradient of {quantity}")

    def finish(self, config, model, store, options, params: Mapping[str, np.ndarray], progress: bool = True) -> None:
        """After every block is written: an analysis of the whole grid adds its
        results to ``store`` (a zarr group path); ``params`` as :func:`jaxwalk.grid.parameter_grid`;
        ``progress``: show a progress bar with the time left (stderr) for work that takes long."""

    def __repr__(self) -> str:
        return f"<analysis {self.name}>"
