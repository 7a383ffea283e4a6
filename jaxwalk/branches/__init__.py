"""``jaxwalk continue``: pseudo-arclength branches from a TOML config, their
dataset and bifurcation diagrams (docs/continuation.md)."""

from jaxwalk.branches.config import ContinueConfig as ContinueConfig, load_continue_config as load_continue_config

__all__ = ["ContinueConfig", "load_continue_config"]
