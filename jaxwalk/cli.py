"""The command line, ``jaxwalk <command> ...``.

Commands:
    sweep CONFIG.toml --out DIR   run a config-driven sweep (docs/sweeps.md)
    simulate CONFIG.toml --steps N --out DIR [--drop H]
                                  walk N steps, record the trajectory, draw it (docs/simulate.md)
    continue CONFIG.toml --out DIR
                                  pseudo-arclength branches of periodic gaits (docs/continuation.md)
    basin CONFIG.toml --out DIR   the basin of attraction on a 2-D slice of the section, an image
                                  and its dataset (docs/global_stability.md)
    plot DATASET [--out DIR] [--vars VAR ...]
                                  heatmaps and line plots of a sweep dataset (docs/plot.md);
                                  bifurcation diagrams of a continuation dataset
    optimize CONFIG.toml --out DIR [--heatmap DATASET]
                                  minimise lambda_max (or another metric) by gradients (docs/optimize.md)
    cache info|clear              the compiled and traced programs kept between runs (docs/cache.md)

Every command takes ``--cache-dir DIR`` (where programs are kept; default
``$JAXWALK_CACHE_DIR``, else ``$XDG_CACHE_HOME/jaxwalk`` or ``~/.cache/jaxwalk``)
and ``--no-cache``, before or after its name.

Each command is a small function ``cmd_<name>(args) -> exit status`` with its
own ``add_<name>`` that declares its arguments; :func:`build_parser` lists
them, so a new command (simulate, plot, optimize) is two functions and a line.

Bad input of any kind (a bad config, an unknown model or parameter, a missing
file, an unusable ``--out``, bad arguments) ends with exactly one line
``jaxwalk: error: <message>`` on stderr, exit status 2, no traceback, and
nothing written.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import warnings
from typing import Callable, Sequence

from jaxwalk.errors import ConfigError

PROG = "jaxwalk"
EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


class UsageError(ConfigError):
    """Bad command-line arguments (raised instead of argparse's multi-line exit);
    a :class:`~jaxwalk.errors.ConfigError`, the root of every user error."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # argparse would print the usage too: keep it to one line
        raise UsageError(message)


class _SubParser(_Parser):
    """A command's parser: it also takes ``--cache-dir`` and ``--no-cache``."""

    def __init__(self, *args, parents=(), **kwargs):
        super().__init__(*args, parents=[*parents, _cache_options()], **kwargs)


# ---------------------------------------------------------------- sweep


def add_sweep(sub) -> None:
    p = sub.add_parser("sweep", help="run a parameter sweep from a TOML config", description=cmd_sweep.__doc__)
    p.add_argument("config", metavar="CONFIG.toml", help="sweep config (see docs/sweeps.md)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory; the dataset is DIR/<name>.zarr")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--dry-run", action="store_true",
        help="compute nothing: print the points, chunks, store size, and the time a previous run of the model suggests",
    )
    p.add_argument("--no-plot", action="store_true", help="no figures DIR/<name>_<variable>_<kind>.png (jaxwalk plot)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing DIR/<name>.zarr")
    p.add_argument("--max-points", type=_positive_int, default=None, metavar="N", help="largest grid accepted (default 10,000,000)")
    p.add_argument(
        "--chunk-size", type=_positive_int, default=None, metavar="N",
        help="grid points per chunk: the unit of work, of resuming and of the zarr chunks (default 256)",
    )
    p.add_argument(
        "--dask", default=None, metavar="ADDRESS",
        help="compute the chunks on a Dask cluster: a scheduler address (tcp://host:8786), or 'local' for one on this machine",
    )
    p.set_defaults(run=cmd_sweep)


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run the sweep in CONFIG.toml and write DIR/<name>.zarr (and its figures, as jaxwalk plot draws them)."""
    from jaxwalk.sweep.config import DEFAULT_MAX_POINTS, load_config
    from jaxwalk.sweep.runner import run_sweep

    config = load_config(args.config, max_points=args.max_points or DEFAULT_MAX_POINTS)
    if args.dry_run:
        from jaxwalk.sweep.runner import dry_run

        print(dry_run(config, args.out, chunk_size=args.chunk_size, overwrite=args.overwrite))
        return EXIT_OK
    path = run_sweep(  # checks --out before computing anything
        config,
        args.out,
        progress=not args.no_progress,
        overwrite=args.overwrite,
        plot=not args.no_plot,
        command=args.command_line,
        chunk_size=args.chunk_size,
        dask=args.dask,
    )
    print(f"wrote {path}: {_status_summary(path)}")
    return EXIT_OK


def _status_summary(path) -> str:
    import numpy as np
    import xarray as xr

    from jaxwalk.status import describe

    with xr.open_dataset(path, engine="zarr") as ds:
        codes, counts = np.unique(ds["status"].values, return_counts=True)
    total = int(counts.sum())
    return f"{total} points, " + ", ".join(f"{int(n)} {describe(c)}" for c, n in zip(codes, counts))


# ---------------------------------------------------------------- simulate


def add_simulate(sub) -> None:
    p = sub.add_parser(
        "simulate", help="walk N steps from the periodic gait; record and draw the trajectory", description=cmd_simulate.__doc__
    )
    p.add_argument("config", metavar="CONFIG.toml", help="model and parameters, optional [simulate] (see docs/simulate.md)")
    p.add_argument("--steps", type=_positive_int, default=None, metavar="N", help="steps to walk (overrides [simulate] steps)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory; the dataset is DIR/<name>_trajectory.zarr")
    p.add_argument(
        "--drop", type=float, default=None, metavar="H",
        help="step-down of height H (vertical, model length units) at the first touchdown (overrides [simulate] drop)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-gif", action="store_true", help="no animation DIR/<name>_walk.gif")
    p.add_argument("--no-plot", action="store_true", help="no figures DIR/<name>_stick.png, DIR/<name>_timeseries.png")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs of the same name")
    p.set_defaults(run=cmd_simulate)


def cmd_simulate(args: argparse.Namespace) -> int:
    """Walk N steps of the model in CONFIG.toml from its periodic gait (or [simulate] v0),
    optionally with a step-down at the first touchdown; write DIR/<name>_trajectory.zarr,
    a stick diagram and time series (PNG) and an animated GIF."""
    from jaxwalk.simulate import load_simulate_config, run_simulation
    from jaxwalk.status import describe

    config = load_simulate_config(args.config, steps=args.steps, drop=args.drop)
    paths, traj = run_simulation(  # checks --out before computing anything
        config, args.out, plot=not args.no_plot, gif=not args.no_gif, overwrite=args.overwrite, command=args.command_line,
        progress=not args.no_progress,
    )
    outcome = f"{traj.steps_completed} of {config.steps} steps"
    if traj.status != 0:
        outcome += f", then {describe(traj.status)} in step {traj.steps_completed}"
    others = ", ".join(str(p) for key, p in paths.items() if key != "dataset")
    print(f"wrote {paths['dataset']}: {outcome}, {len(traj.time)} samples" + (f"; {others}" if others else ""))
    return EXIT_OK


# ---------------------------------------------------------------- continue


def _is_continuation(path: str) -> bool:
    """Whether ``path`` is a ``jaxwalk continue`` dataset (its zarr attributes say kind = continuation)."""
    import json
    from pathlib import Path

    meta = Path(path) / "zarr.json"
    try:
        return json.loads(meta.read_text()).get("attributes", {}).get("kind") == "continuation"
    except (OSError, ValueError):
        return False


def add_continue(sub) -> None:
    p = sub.add_parser("continue", help="pseudo-arclength branches of periodic gaits from a TOML config",
                       description=cmd_continue.__doc__)
    p.add_argument("config", metavar="CONFIG.toml", help="continuation config (docs/continuation.md)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace an existing dataset")
    p.add_argument("--no-progress", action="store_true", help="no stage lines or progress bar")
    p.set_defaults(run=cmd_continue)


def cmd_continue(args: argparse.Namespace) -> int:
    """Continue the period-k gaits of CONFIG.toml's model in one parameter through folds
    (pseudo-arclength), locate folds, flips and Neimark-Sacker points on the branches,
    optionally switch onto the period-2k branch at each flip; write DIR/<name>_branches.zarr."""
    from jaxwalk.branches import load_continue_config
    from jaxwalk.branches.run import run_continue

    config = load_continue_config(args.config)
    path, ds = run_continue(config, args.out, overwrite=args.overwrite, command=args.command_line,
                            progress=not args.no_progress)
    print(f"wrote {path}: {ds.sizes['branch']} branches, {ds.sizes['label']} labelled points")
    return EXIT_OK


# ---------------------------------------------------------------- basin


def add_basin(sub) -> None:
    p = sub.add_parser("basin", help="draw a gait's basin of attraction on two section coordinates",
                       description=cmd_basin.__doc__)
    p.add_argument("config", metavar="CONFIG.toml", help="basin config (docs/global_stability.md)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory: DIR/<name>_basin.zarr and DIR/<name>_basin.png")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs of the same name")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_basin)


def cmd_basin(args: argparse.Namespace) -> int:
    """Walk a grid of starts about the gait of CONFIG.toml's model, two section coordinates
    varied and the others at the fixed point, all at once; write each start's fate
    (returned, the failing status, not returned) and steps to DIR/<name>_basin.zarr and
    draw them, DIR/<name>_basin.png."""
    from jaxwalk.basin import load_basin_config
    from jaxwalk.basin.run import run_basin
    from jaxwalk.status import describe

    import numpy as np

    config = load_basin_config(args.config)
    paths, ds = run_basin(config, args.out, overwrite=args.overwrite, command=args.command_line,
                          progress=not args.no_progress)
    codes, counts = np.unique(ds["outcome"].values, return_counts=True)
    summary = ", ".join(f"{int(n)} {describe(c)}" for c, n in zip(codes, counts))
    print(f"wrote {paths['dataset']}, {paths['image']}: {int(counts.sum())} starts, {summary}")
    return EXIT_OK


# ---------------------------------------------------------------- plot


def add_plot(sub) -> None:
    from jaxwalk.analyses import plotted

    p = sub.add_parser("plot", help="heatmaps and line plots of a sweep dataset", description=cmd_plot.__doc__)
    p.add_argument("dataset", metavar="DATASET", help="a sweep dataset, DIR/<name>.zarr")
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: the dataset's directory)")
    p.add_argument(
        "--vars", nargs="+", default=None, metavar="VAR",
        help=f"variables to draw (default: {' '.join(plotted())}, those with values)",
    )
    p.add_argument(
        "--kind", action="append", choices=("heatmap", "lines"), default=None,
        help="figure kind, repeatable (default: lines, and heatmaps when two axes have more than one value)",
    )
    p.add_argument("--x", default=None, metavar="AXIS", help="horizontal axis (default: the longest)")
    p.add_argument("--y", default=None, metavar="AXIS", help="heatmap vertical axis / one curve per value (default: the next longest)")
    p.add_argument(
        "--at", action="append", default=None, metavar="AXIS=INDEX",
        help="hold a further grid axis at this index, repeatable (default: a third axis as small multiples, others at index 0)",
    )
    p.add_argument("--format", default="png", choices=("png", "pdf", "svg"), help="file format (default png)")
    p.add_argument(
        "--partial", action="store_true",
        help="draw an unfinished or damaged dataset's computed points (the rest marked 'not computed') instead of refusing it",
    )
    p.set_defaults(run=cmd_plot)


def cmd_plot(args: argparse.Namespace) -> int:
    """Draw heatmaps (with the lambda_max = 1 contour) and line plots of a sweep
    dataset's lambda_max, h_max, speed and cost of transport, failures masked and
    named by status; one file per figure, DIR/<name>_<variable>_<kind>.<format>."""
    from jaxwalk.plot import plot_dataset

    if _is_continuation(args.dataset):
        return _plot_continuation(args)
    paths = plot_dataset(
        args.dataset, args.out, fmt=args.format, partial=args.partial, variables=args.vars, kinds=args.kind, x=args.x, y=args.y, at=args.at or None
    )
    for path in paths:
        print(f"wrote {path}")
    return EXIT_OK


def _plot_continuation(args: argparse.Namespace) -> int:
    """``jaxwalk plot`` of a ``jaxwalk continue`` dataset: every choice checked before the first figure."""
    from pathlib import Path

    import xarray as xr

    from jaxwalk.branches.diagram import plot_branches, quantity

    given = [f"--{k}" for k in ("kind", "x", "y", "at", "partial") if getattr(args, k)]
    if given:
        raise UsageError(f"{', '.join(given)}: not for a continuation dataset (its figures: --vars lambda_max v0 ...)")
    out = Path(args.out) if args.out else Path(args.dataset).parent
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out '{out}' exists and is not a directory")
    ys = args.vars or ("lambda_max", "v0")
    with xr.open_zarr(args.dataset) as ds:
        for y in ys:
            try:
                quantity(ds, y)
            except ValueError as err:
                raise UsageError(str(err)) from None
    for y in ys:
        print(f"wrote {plot_branches(args.dataset, out, y, args.format)}")
    return EXIT_OK


# ---------------------------------------------------------------- optimum


def add_optimum(sub) -> None:
    p = sub.add_parser(
        "optimum", help="the best point of every line of a sweep (r* per foot length) and its kind",
        description=cmd_optimum.__doc__,
    )
    p.add_argument("dataset", metavar="DATASET", help="a sweep dataset, DIR/<name>.zarr")
    p.add_argument("--var", default="lambda_max", metavar="VAR", help="the variable to optimise (default lambda_max)")
    p.add_argument("--along", default="r", metavar="AXIS", help="the grid axis the lines run along (default r)")
    p.add_argument("--max", action="store_true", help="the largest value is best (h_max); default: the least")
    p.add_argument("--csv", default=None, metavar="FILE", help="also write the table as CSV")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --csv file")
    p.set_defaults(run=cmd_optimum)


def cmd_optimum(args: argparse.Namespace) -> int:
    """Print, for every line of a sweep along one grid axis, its best walking
    point, the variable there, and whether that optimum is interior (refined by
    a parabola through the grid points), pressed against the edge of the
    walking band (with the status beyond it), at the grid's edge, or a plateau."""
    from jaxwalk.api import open_dataset
    from jaxwalk.files import check_file, write_atomically
    from jaxwalk.status import describe
    from jaxwalk.sweep.optimum import KINDS, line_optima

    if args.csv:
        check_file(args.csv, "--csv", overwrite=args.overwrite)
    optima = line_optima(open_dataset(args.dataset), args.var, args.along, "max" if args.max else "min")
    table = optima.to_dataframe().reset_index()
    table["optimum_kind"] = [KINDS[k] for k in table["optimum_kind"]]
    table["beyond_status"] = [describe(int(c)) if c >= 0 else "" for c in table["beyond_status"]]
    table = table.rename(columns={"star": f"{args.along}*", "value": args.var})
    print(_markdown(table))
    if args.csv:
        write_atomically(args.csv, lambda path: table.to_csv(path, index=False))
        print(f"wrote {args.csv}")
    return EXIT_OK


def _markdown(table) -> str:
    """A DataFrame as a Markdown table, numbers to 4 significant digits."""
    cell = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)
    rows = [list(table.columns), ["---"] * len(table.columns)] + [[cell(v) for v in row] for row in table.itertuples(index=False)]
    return "\n".join("| " + " | ".join(row) + " |" for row in rows)


# ---------------------------------------------------------------- optimize


def add_optimize(sub) -> None:
    p = sub.add_parser(
        "optimize", help="minimise lambda_max (or speed, ...) over parameters by gradients", description=cmd_optimize.__doc__
    )
    p.add_argument("config", metavar="CONFIG.toml", help="optimisation config (see docs/optimize.md)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory; the path is DIR/<name>.zarr, the figure DIR/<name>.png")
    p.add_argument("--heatmap", default=None, metavar="DATASET", help="a sweep dataset (zarr) to draw the paths over, instead of computing [heatmap]")
    p.add_argument("--no-heatmap", action="store_true", help="no background grid")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-plot", action="store_true", help="no figure DIR/<name>.png")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs of the same name")
    p.set_defaults(run=cmd_optimize)


def cmd_optimize(args: argparse.Namespace) -> int:
    """Minimise the objective of CONFIG.toml over its bounded parameters from every start
    at once (projected optax steps on implicit-function gradients at the gait); write the path
    DIR/<name>.zarr and draw it over the lambda_max heatmap, DIR/<name>.png."""
    from jaxwalk.optimize import load_optimize_config, run_optimize, summary

    if args.heatmap is not None and args.no_heatmap:
        raise UsageError("--heatmap and --no-heatmap contradict each other: give one")
    config = load_optimize_config(args.config)
    path, ds = run_optimize(  # checks --out (and --heatmap) before computing anything
        config, args.out, heatmap_path=args.heatmap, heatmap=not args.no_heatmap, plot=not args.no_plot,
        overwrite=args.overwrite, command=args.command_line, progress=not args.no_progress,
    )
    print(f"wrote {path}: {summary(ds)}")
    return EXIT_OK


# ---------------------------------------------------------------- cache


def add_cache(sub) -> None:
    p = sub.add_parser(
        "cache", help="show or clear the compiled and traced programs kept between runs", description=cmd_cache.__doc__
    )
    p.add_argument("action", choices=("info", "clear"), help="info: where and how much; clear: delete them")
    p.set_defaults(run=cmd_cache)


def cmd_cache(args: argparse.Namespace) -> int:
    """Where jaxwalk keeps compiled (XLA) and traced (StableHLO) programs and how much
    they take (info), or delete them (clear); the next run compiles afresh."""
    from jaxwalk import cache

    if cache.directory() is None:
        print("caches off (--no-cache, or JAXWALK_CACHE_DIR set empty)")
        return EXIT_OK
    found = cache.clear() if args.action == "clear" else cache.info()
    verb = "removed" if args.action == "clear" else "holds"
    print(
        f"{found.directory} {verb} {found.compiled_files} compiled ({_mib(found.compiled_bytes)}) and "
        f"{found.traced_files} traced programs ({_mib(found.traced_bytes)})"
    )
    return EXIT_OK


def _mib(n: int) -> str:
    return f"{n / 2**20:.1f} MiB"


def _cache_options() -> argparse.ArgumentParser:
    """``--cache-dir`` and ``--no-cache``, accepted before and after the command's name
    (``SUPPRESS``: a subcommand's absent option does not hide the main parser's)."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument(
        "--cache-dir", default=argparse.SUPPRESS, metavar="DIR",
        help="keep compiled and traced programs in DIR (default $JAXWALK_CACHE_DIR, else ~/.cache/jaxwalk)",
    )
    p.add_argument("--no-cache", action="store_true", default=argparse.SUPPRESS, help="keep no programs: compile afresh")
    return p


def _configure_cache(args: argparse.Namespace) -> None:
    from jaxwalk import cache

    if getattr(args, "no_cache", False) and getattr(args, "cache_dir", None) is not None:
        raise UsageError("--no-cache and --cache-dir contradict each other: give one")
    if getattr(args, "no_cache", False):
        cache.configure(enabled=False)
    elif getattr(args, "cache_dir", None) is not None:
        problem = cache.unusable(args.cache_dir) if getattr(args, "run", None) is cmd_cache else None
        if problem:  # for the cache command the directory is the input, not a preference
            raise UsageError(f"--cache-dir '{args.cache_dir}' cannot be used: {problem}")
        cache.configure(args.cache_dir)
    else:
        default = cache.default_directory()
        problem = cache.unusable(default) if default is not None and getattr(args, "run", None) is cmd_cache else None
        if problem:
            raise UsageError(f"the cache directory '{default}' ({cache.ENV}, JAX_COMPILATION_CACHE_DIR or the default) "
                             f"cannot be used: {problem}")
        cache.report()  # the default directory, configured by ``import jaxwalk``


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as the command line's other messages: one line, no source; above
    any progress bar (a warning from a worker or background thread would
    otherwise split the bar's line)."""
    from tqdm import tqdm

    tqdm.write(f"{PROG}: warning: {' '.join(str(message).split())}", file=sys.stderr if file is None else file)


# ---------------------------------------------------------------- parser

#: The commands, in the order ``--help`` lists them.
COMMANDS: tuple[Callable, ...] = (
    add_sweep, add_simulate, add_continue, add_basin, add_plot, add_optimum, add_optimize, add_cache,
)


def build_parser() -> argparse.ArgumentParser:
    from jaxwalk import __version__

    parser = _Parser(
        prog=PROG, description="JAX-vectorised stability analysis of dynamic walkers.", parents=[_cache_options()]
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=_SubParser)
    for add in COMMANDS:
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    warnings.showwarning = _one_line_warning
    try:
        args = build_parser().parse_args(argv)
        args.command_line = shlex.join([PROG, *argv])
        _configure_cache(args)
        return args.run(args)
    except ConfigError as err:  # UsageError among them
        return _fail(str(err), EXIT_USAGE)
    except OSError as err:  # the disk, not the input: still one line
        return _fail(f"{f'{err.filename}: ' if err.filename else ''}{err.strerror or err}", EXIT_FAILED)
    except KeyboardInterrupt as err:  # a sweep's says what it kept and how to continue
        return _fail(str(err) or "interrupted", 130)


def _fail(message: str, status: int) -> int:
    print(f"{PROG}: error: {' '.join(message.split())}", file=sys.stderr)
    return status


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value
