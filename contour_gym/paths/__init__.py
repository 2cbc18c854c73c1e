"""Geometry: contours parameterised by arc length, compiled to one table format.

Every path (line, arc, circle, polyline, helix, composite, parametric, B-spline, NURBS, G-code,
named library paths) compiles to a :class:`PathTable` of LINE, HELIX and POLY5 segments. The
numba functions in :mod:`contour_gym.paths._geom` (``eval_path``, ``find_segment``,
``nearest_segment``, ``side_2d``) evaluate it and find exact nearest points on a segment;
:mod:`contour_gym.paths._branch` holds the true contour error's one definition (the nearest
point of the branch a machine is on) and its search, for the Python API here and for the
servo-loop kernel.

Units are SI (metres). 2-D paths keep z = 0 in the table. Signed distances in 2-D are positive
to the left of the direction of travel.
"""

from __future__ import annotations

from contour_gym.paths._freeform import bspline, nurbs, parametric
from contour_gym.paths._gcode import WORK_SYSTEMS, GcodeError, GcodePath, from_gcode
from contour_gym.paths._gcode_feeds import feed_grid, feed_moves, rewrite_feeds
from contour_gym.paths._gcode_split import split_moves
from contour_gym.paths._geom import HELIX, LINE, POLY5
from contour_gym.paths._library import NAMES, load
from contour_gym.paths._path import Path
from contour_gym.paths._primitives import arc, circle, composite, helix, line, polyline
from contour_gym.paths._random import PATH_FAMILIES, random_path, random_paths
from contour_gym.paths._table import PathTable
from contour_gym.paths._timelaw import TimeLaw

__all__ = [
    "HELIX",
    "LINE",
    "NAMES",
    "PATH_FAMILIES",
    "POLY5",
    "GcodeError",
    "GcodePath",
    "Path",
    "PathTable",
    "WORK_SYSTEMS",
    "TimeLaw",
    "arc",
    "bspline",
    "circle",
    "composite",
    "feed_grid",
    "feed_moves",
    "from_gcode",
    "helix",
    "line",
    "load",
    "nurbs",
    "parametric",
    "polyline",
    "random_path",
    "random_paths",
    "rewrite_feeds",
    "split_moves",
]
