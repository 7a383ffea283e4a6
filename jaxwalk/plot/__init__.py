"""Figures of a sweep dataset (``jaxwalk plot``): heatmaps and line plots with
failures masked and named by status. See ``docs/plot.md``.

``source`` opens and checks a dataset and picks its variables, ``layout``
decides which grid axis goes where, ``statuses`` names and colours failures,
``heatmap`` and ``lines`` draw, ``output`` names and writes the files, ``plan``
ties them together. Every drawing function returns a
:class:`matplotlib.figure.Figure` (no pyplot, no global state).
"""

from jaxwalk.plot.heatmap import heatmap_figure as heatmap_figure
from jaxwalk.plot.layout import Layout as Layout, choose_layout as choose_layout
from jaxwalk.plot.lines import lines_figure as lines_figure
from jaxwalk.plot.output import FORMATS as FORMATS, figure_path as figure_path, save_figure as save_figure
from jaxwalk.plot.plan import KINDS as KINDS, make_figures as make_figures, plot_dataset as plot_dataset
from jaxwalk.plot.source import PlotError as PlotError, open_sweep as open_sweep
