"""The model registry: every model by its name.

A new model is one module here (a :class:`jaxwalk.walker.Walker` subclass)
and one entry in :data:`MODELS`; ``tests/test_walker_contract.py`` then
checks it against the walker contract. Models compare by value, so a second
instance of a model class shares every compiled program with the registry's.
"""

from __future__ import annotations

from jaxwalk.models.compass import CompassWalker as CompassWalker
from jaxwalk.models.flatfoot import FlatFootHeelRiseWalker as FlatFootHeelRiseWalker, FlatFootWalker as FlatFootWalker
from jaxwalk.models.kneed import KneedStopWalker as KneedStopWalker, KneedWalker as KneedWalker
from jaxwalk.models.simplest import SimplestWalker as SimplestWalker
from jaxwalk.walker import Walker

MODELS: dict[str, Walker] = {
    m.name: m
    for m in (SimplestWalker(), CompassWalker(), KneedWalker(), KneedStopWalker(), FlatFootWalker(), FlatFootHeelRiseWalker())
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
