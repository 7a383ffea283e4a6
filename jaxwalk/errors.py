"""The one error root for user errors.

Every problem with what a user gave (a config file, a command-line option, an
output directory, a store on disk) is a :class:`ConfigError` or a subclass of
it (``GaitNotFound``, ``IncompleteStore``, ``PlotError``): the command line
prints ``jaxwalk: error: <message>`` and exits with status 2, and the Python
API documents this one type (``docs/python.md``). Anything else that escapes
is a bug in jaxwalk, not in the input.

This module imports nothing, so that any module may raise the error without
pulling in a config parser.
"""

from __future__ import annotations


class ConfigError(Exception):
    """A user's input is unusable. ``str(err)`` is one line, fit for a terminal."""
