"""Progress of the work inside one block of a sweep: a second bar under the sweep's.

A sweep's bar (:mod:`jaxwalk.sweep.runner`) advances when a block is written.
Some analyses spend many minutes inside one block (the MFPT's chain: thousands
of step maps per gait, 5 gaits of the flat-foot walker took over 25 minutes),
where that bar would sit still with no estimate. They report their own work
through :func:`stage`, which draws a bar of its own (count, rate, time left)
under the sweep's and removes it when the stage ends.

A stage draws only inside :func:`shown`, which the sweep's runner opens when
its own bar is on; elsewhere (the Python API, Dask workers, the tests) a stage
prints nothing and costs one context-variable lookup.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
from typing import Callable, Iterator

#: ``advance(n)``: ``n`` more units of a stage's work are done.
Advance = Callable[[int], None]

_SHOWN: contextvars.ContextVar[bool] = contextvars.ContextVar("jaxwalk_stage_bars", default=False)

#: A stage shorter than this (seconds) never draws: quick blocks stay one line.
DELAY = 2.0


@contextlib.contextmanager
def shown(enabled: bool = True) -> Iterator[None]:
    """Within it, :func:`stage` draws its bar (``enabled=False``: it does not)."""
    token = _SHOWN.set(enabled)
    try:
        yield
    finally:
        _SHOWN.reset(token)


@contextlib.contextmanager
def stage(desc: str, total: int, unit: str) -> Iterator[Advance]:
    """A stage of ``total`` units of work (``unit`` names one); yields ``advance(n)``.

    Inside :func:`shown`, a bar one line under the sweep's, drawn once the stage
    has run :data:`DELAY` seconds and gone when it ends; elsewhere ``advance``
    does nothing."""
    if not _SHOWN.get() or total <= 0:
        yield _ignore
        return
    from tqdm.auto import tqdm

    with tqdm(total=total, desc=desc, unit=unit, position=1, leave=False, file=sys.stderr, delay=DELAY) as bar:
        yield bar.update


def _ignore(n: int) -> None:
    del n
