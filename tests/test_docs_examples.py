"""Every example in README.md and docs/ runs: the command lines of their ```bash
blocks and the Python of their ```python blocks, extracted from the files.

Small: sweeps run for real on the bundled simplest-walker config (its programs
compile once for the module); a simulate, optimize or basin command is parsed and its
config checked (walking the kneed walker, optimising or walking a basin's
thousands of starts takes minutes), a Dask
cluster command likewise. Outputs go to a temporary directory.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from jaxwalk import cli

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"```(bash|python)\n(.*?)```", re.S)
#: Commands that compute for minutes, or need a cluster: checked, not run.
CHECKED_ONLY = ("simulate", "optimize", "basin")


def examples(kind: str) -> list[tuple[str, str]]:
    """``(file, text)`` of every ``kind`` block."""
    return [(p.name, m.group(2)) for p in DOCS for m in BLOCK.finditer(p.read_text()) if m.group(1) == kind]


def command_lines() -> list[tuple[str, list[str]]]:
    """Each ``jaxwalk ...`` line of a bash block, as arguments (comments dropped)."""
    out = []
    for name, text in examples("bash"):
        for line in text.splitlines():
            line = line.split(" #")[0].strip()
            if ".venv/bin/jaxwalk " in line:  # README's set-up line: its last command
                line = "jaxwalk " + line.split(".venv/bin/jaxwalk ", 1)[1]
            if line.startswith("jaxwalk "):
                out.append((name, shlex.split(line)[1:]))
    return out


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A directory with the bundled configs, as a clone's root (outputs land in it)."""
    tmp = tmp_path_factory.mktemp("docs")
    (tmp / "sweeps").symlink_to(ROOT / "sweeps")
    return tmp


def test_the_docs_have_examples():
    lines = command_lines()
    assert any(args[0] == "sweep" for _, args in lines) and any(args[0] == "plot" for _, args in lines)
    assert len(examples("python")) >= 5


@pytest.mark.slow
def test_every_command_line_runs(workdir, monkeypatch, capsys):
    monkeypatch.chdir(workdir)
    # Sweeps first: plot examples draw what they wrote.
    ordered = sorted(command_lines(), key=lambda item: item[1][0] != "sweep")
    for name, args in ordered:
        if "--dask" in args:  # a cluster's scheduler: the config is what can be checked here
            args = [a for a in args if not a.startswith("tcp://") and a != "--dask"]
            if not Path(args[1]).exists():
                continue  # sweeps/big.toml: a placeholder for the user's own config
        if args[0] in CHECKED_ONLY:
            parsed = cli.build_parser().parse_args(args)
            loader = {"simulate": "load_simulate_config", "optimize": "load_optimize_config", "basin": "load_basin_config"}[args[0]]
            module = __import__(f"jaxwalk.{args[0]}", fromlist=[loader])
            getattr(module, loader)(parsed.config)
            continue
        status = cli.main(args + (["--overwrite"] if args[0] == "sweep" and "--overwrite" not in args else []))
        assert status == 0, f"{name}: jaxwalk {shlex.join(args)}: {capsys.readouterr().err}"
    assert (workdir / "results" / "slopes" / "simplest_slope.zarr").is_dir()
    assert (workdir / "figs" / "simplest_slope_lambda_max_lines.pdf").is_file()


@pytest.mark.slow
def test_every_python_example_runs(workdir, monkeypatch):
    """Blocks in file order, one namespace per file (a notebook's cells); the
    simulate and optimize calls of docs/python.md are left to their commands' tests.
    Figures are drawn off screen (Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(workdir)
    # The stores the examples read, as the commands before them in the docs write them.
    assert cli.main(["sweep", "sweeps/compass_flip_locus.toml", "--out", "results/quickstart", "--overwrite", "--no-plot"]) == 0
    assert cli.main(["sweep", "sweeps/simplest_slope.toml", "--out", "results/slopes", "--overwrite", "--no-plot"]) == 0
    namespaces: dict[str, dict] = {}
    ran = 0
    for name, text in examples("python"):
        # Walks and optimisations (minutes; their commands' configs are checked above)
        # and the flat-foot walker's gait (about a minute to trace and compile).
        if any(s in text for s in ("simulate", "optimize(", "FlatFootWalker")):
            continue
        namespace = namespaces.setdefault(name, {})
        exec(compile(text, f"{name} example", "exec"), namespace)
        ran += 1
    assert ran >= 5
