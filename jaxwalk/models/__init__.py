"""The model registry: one shared instance per model, looked up by name.

Jitted functions close over a model and use its Python identity as their cache
key (see :class:`jaxwalk.walker.Walker`), so everything should get its model
from here rather than constructing a new one.
"""

from __future__ import annotations

from jaxwalk.models.compass import CompassWalker
from jaxwalk.models.flatfoot import FlatFootWalker
from jaxwalk.models.kneed import KneedStopWalker, KneedWalker
from jaxwalk.models.simplest import SimplestWalker
from jaxwalk.walker import Walker

MODELS: dict[str, Walker] = {
    m.name: m
    for m in (SimplestWalker(), CompassWalker(), KneedWalker(), KneedStopWalker(), FlatFootWalker())
}


def get_model(name: str) -> Walker:
    """The registered model called ``name``.

    Raises:
        KeyError: with a one-line message listing the known models.
    """
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown model '{name}' (known: {', '.join(MODELS)})") from None
