"""The flat-foot walker: see :mod:`jaxwalk.models.flatfoot.model` and ``docs/model.md``."""

from jaxwalk.models.flatfoot.model import FlatFootHeelRiseWalker as FlatFootHeelRiseWalker, FlatFootWalker as FlatFootWalker
