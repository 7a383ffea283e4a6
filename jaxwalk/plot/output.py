"""Figure files: their names and an atomic write.

One file per figure, ``<dataset name>_<variable>_<kind>.<format>`` (for example
``flatfoot_r_lf_lambda_max_heatmap.png``), written to a hidden temporary file
in the same directory and renamed into place (:func:`jaxwalk.files.write_atomically`),
so a reader never sees half a figure and a failed draw leaves nothing behind.
"""

from __future__ import annotations

import os
from pathlib import Path

from jaxwalk.files import write_atomically

#: File formats ``jaxwalk plot --format`` writes.
FORMATS = ("png", "pdf", "svg")
#: Raster resolution of PNGs (dots per inch): sharp on screen, a few hundred kB.
DPI = 150


def figure_path(out_dir: str | os.PathLike, dataset_name: str, variable: str, kind: str, fmt: str = "png") -> Path:
    """``out_dir/<dataset_name>_<variable>_<kind>.<fmt>``."""
    return Path(out_dir) / f"{dataset_name}_{variable}_{kind}.{fmt}"


def save_figure(fig, path: str | os.PathLike, fmt: str = "png", *, dpi: int = DPI) -> Path:
    """Write ``fig`` (a :class:`matplotlib.figure.Figure`) to ``path`` as ``fmt``, atomically."""
    # Metadata without a date: the same data gives the same file.
    metadata = {"Software": "jaxwalk"} if fmt == "png" else {"Creator": "jaxwalk"}
    if fmt == "pdf":
        metadata["CreationDate"] = None
    elif fmt == "svg":
        metadata = {"Creator": "jaxwalk", "Date": None}
    return write_atomically(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=dpi, metadata=metadata))
