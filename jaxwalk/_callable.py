"""Packages that are also functions: ``jaxwalk.sweep(config)`` runs a sweep while
``jaxwalk.sweep.runner`` stays a module (the notebook API, :mod:`jaxwalk.api`)."""

from __future__ import annotations

import sys
import types


def make_callable(module_name: str, function_name: str) -> None:
    """Calling the module ``module_name`` calls ``jaxwalk.api.<function_name>``."""

    class CallablePackage(types.ModuleType):
        def __call__(self, *args, **kwargs):
            from jaxwalk import api

            return getattr(api, function_name)(*args, **kwargs)

    CallablePackage.__call__.__doc__ = f"jaxwalk.api.{function_name}: see its docstring"
    sys.modules[module_name].__class__ = CallablePackage
