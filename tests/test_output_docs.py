"""The declared outputs (:mod:`jaxwalk.outputs`, :mod:`jaxwalk.analyses`) against what
describes them to a user: docs/sweeps.md's table of dataset variables, the
``--vars`` help of ``jaxwalk plot`` and docs/plot.md's default variables. No JAX, no dataset: text only."""

from __future__ import annotations

import re

import pytest

from jaxwalk import analyses, cli
from tests.conftest import ROOT

HEADER = "| variable | dims | dtype | units | meaning |"
#: How docs/sweeps.md writes each units template of the schema.
UNITS_IN_DOCS = {None: "", "1": "1", "steps": "steps", "{length}": "model length", "{time}": "model time",
                 "{speed}": "model length / time", "{energy}": "model energy"}


def table_rows() -> list[tuple[list[str], str, str, str]]:
    """``(names, dims, dtype, units)`` of each row of the dataset-variable table.
    A name written ``_imag`` after ``x_real`` is ``x_imag``."""
    text = (ROOT / "docs" / "sweeps.md").read_text()
    assert text.count(HEADER) == 1
    lines = text.split(HEADER, 1)[1].splitlines()[2:]  # past the |---| line
    rows = []
    for line in lines:
        if not line.startswith("|"):
            break
        variable, dims, dtype, units = (c.strip() for c in line.strip().strip("|").split("|", 4)[:4])
        names = []
        for name in re.findall(r"`([^`]+)`", variable):
            names.append(names[-1].rsplit("_", 1)[0] + name if name.startswith("_") else name)
        rows.append((names, dims, dtype, units))
    return rows


def dataset_names(output) -> list[str]:
    return [f"{output.name}_real", f"{output.name}_imag"] if output.is_complex else [output.name]


def per_point_rows():
    """The rows of variables over the grid (the others, along ``bifurcation``, are the
    bifurcation table, written whole by its analysis rather than declared per point)."""
    rows = table_rows()
    assert all(dims.startswith(("grid", "`bifurcation`")) for _, dims, _, _ in rows), rows
    return [r for r in rows if r[1].startswith("grid")]


def test_the_table_lists_every_declared_output_and_nothing_else():
    documented = [n for names, *_ in per_point_rows() for n in names]
    declared = [n for o in analyses.declared() for n in dataset_names(o)]
    assert len(documented) == len(set(documented)), "a variable is documented twice"
    assert sorted(set(declared) - set(documented)) == [], "declared but not in docs/sweeps.md"
    assert sorted(set(documented) - set(declared)) == [], "in docs/sweeps.md but declared by no analysis"


@pytest.mark.parametrize("row", per_point_rows(), ids=lambda r: r[0][0])
def test_each_row_has_the_declared_dims_dtype_and_units(row):
    names, dims, dtype, units = row
    by_name = {n: o for o in analyses.declared() for n in dataset_names(o)}
    unit_cells = units.split(", ") if len(names) > 1 and units.count(", ") == len(names) - 1 else [units] * len(names)
    for name, unit in zip(names, unit_cells):
        o = by_name[name]
        assert dims == ", ".join(["grid", *(f"`{t}`" for t in o.trailing)]), name
        assert dtype == ("float64" if o.is_complex else o.dtype), name
        if not callable(o.units):  # a rule over the model's units (the gait sensitivity norm's): prose
            assert unit == UNITS_IN_DOCS[o.units], name


def test_plot_help_names_the_default_variables(capsys):
    with pytest.raises(SystemExit):
        cli.main(["plot", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert f"(default: {' '.join(analyses.plotted())}, those with values)" in help_text
    assert analyses.plotted()[:2] == ("lambda_max", "h_max")  # stability measures first


def test_docs_plot_names_every_default_variable():
    text = (ROOT / "docs" / "plot.md").read_text().split("## What is drawn", 1)[1].split("\n## ", 1)[0]
    named = re.findall(r"`([a-z_]+)`", text)
    first = list(dict.fromkeys(n for n in named if n in analyses.plotted()))  # each at its first mention
    assert first == list(analyses.plotted())
