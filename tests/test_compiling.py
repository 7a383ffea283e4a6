"""How a walker's programs are compiled (``jaxwalk.compiling``): the model's XLA
options reach every top-level program, the exported ones loaded from the disk
cache included, and JAX's refusal of options on a nested ``jit`` is met."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxwalk import cache, compiling, program_cache
from jaxwalk.models import get_model

ELEMENTAL = (("xla_cpu_use_fusion_emitters", False),)
#: The options are the CPU backend's; elsewhere every walker compiles with XLA's defaults.
cpu_only = pytest.mark.skipif(jax.default_backend() != "cpu", reason="the compiler options are the CPU backend's")


def _options(lowered) -> tuple:
    """The compiler options a lowering will be compiled with (JAX keeps them privately)."""
    return tuple(lowered._lowering._compiler_options_kvs or ())


@cpu_only
@pytest.mark.parametrize("name, expected", [("flatfoot", ELEMENTAL), ("kneed", ELEMENTAL), ("kneed_stop", ELEMENTAL),
                                            ("compass", ()), ("simplest", ())])
def test_each_walker_compiles_with_its_measured_options(name, expected):
    """The choice benchmarks/bench_compile_options.py measured, per walker (a
    subclass inherits it)."""
    model = get_model(name)
    program = compiling.jit(lambda x: 2.0 * x, model)
    assert _options(program.lower(jnp.ones(3))) == expected
    assert (compiling.compiler_options(model) is None) == (expected == ())


@pytest.fixture
def disk_cache(tmp_path, monkeypatch):
    before = cache.directory()
    monkeypatch.setenv("EQX_ON_ERROR", "nan")
    monkeypatch.setenv(cache.ENV, str(tmp_path))  # configure() writes it; restored after
    cache.configure(tmp_path)
    yield tmp_path
    cache.configure(before, enabled=before is not None)


@cpu_only
@pytest.mark.parametrize("name, expected", [("flatfoot", ELEMENTAL), ("simplest", ())])
def test_an_exported_program_is_compiled_with_the_models_options(disk_cache, name, expected):
    """A registered program runs as exported (traced, saved, then loaded): the
    ``jit`` that compiles the export is not the one that was traced, and must
    be given the model's options again; the numbers are the program's."""
    model = get_model(name)
    program = compiling.jit(lambda x: jnp.sin(x) + 1.0, model)
    program_cache.register(program, "test_compiling", model)
    x = np.linspace(0.0, 1.0, 5)
    for run in range(2):  # the first run exports and saves, the second loads
        loaded = program_cache.counts["loaded"]
        lowered = program_cache.lower(program, x)
        assert program_cache.counts["loaded"] == loaded + run
        assert _options(lowered) == expected
        np.testing.assert_allclose(np.asarray(lowered.compile()(x)), np.sin(x) + 1.0, rtol=1e-15)
    assert len(list((disk_cache / "jaxwalk-programs").glob("*.jaxexport"))) == 1


def test_options_on_a_nested_jit_are_refused_by_jax_so_building_blocks_stay_plain():
    """Why ``find_gait`` and ``run_step`` are plain ``jax.jit``: a program with
    options cannot be called inside another (if JAX ever allows it, the
    building blocks could carry the model's options too)."""
    inner = compiling.jit(lambda x: 2.0 * x, get_model("flatfoot"))
    with pytest.raises(ValueError, match="top-level"):
        jax.jit(lambda x: inner(x) + 1.0)(jnp.ones(2))
