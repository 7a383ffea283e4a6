"""The model registry: one shared instance per model, looked up by name.

Jitted functions close over a model and use its Python identity as their cache
key (see :class:`jaxwalk.walker.Walker`), so everything should get its model
from here rather than constructing a new one.
"""

from __future__ import annotations

from jaxwalk.models.compass import CompassWalker
from jaxwalk.models.kneed import KneedStopWalker, KneedWalker
from jaxwalk.models.simplest import SimplestWalker
from jaxwalk.walker import Walker

MODELS: dict[str, Walker] = {m.name: m for m in (SimplestWalker(), CompassWalker())}

try:
    from jaxwalk.models.kneed import KneedWalker
except ModuleNotFoundError as err:  # not written yet; any other import error is a bug and surfaces
    if err.name != "jaxwalk.models.kneed":
        raise
else:
    MODELS[KneedWalker.name] = KneedWalker()


def get_model(name: str) -> Walker:
    """The registered model called ``name``.

    Raises:
        KeyError: no such model; the one-line message (``err.args[0]``) lists the known ones.
    """
    try:
        return MODELS[name]
    except (KeyError, TypeError):
        raise KeyError(f"unknown model {name!r} (known: {', '.join(MODELS)})") from None
