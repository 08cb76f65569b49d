"""cbfgen: code-generated Exponential-CBF safety filters, from Python.

Every built-in system (``systems()``), and a spec of your own loaded with
:func:`load` (generated, built as a plugin and cached on first use), is reached through
the same classes, all the Rust crate's through pyo3:

* :class:`System`: a system by name — sizes, state and input names, input limits, its
  barrier families, the dynamics (:meth:`System.drift`, :meth:`System.input_matrix`,
  :meth:`System.xdot`) and every row at a state (:meth:`System.rows`);
* :class:`Params`: each family's run-time instances, set by family name (``set``,
  ``push``, ``remove``, ``clear``, ``set_enabled``);
* :class:`EcbfFilter`: the ECBF-QP safety filter of any system, and its
  :class:`FilterOutput`;
* the smooth SAT of two boxes: :func:`ssat`, :func:`ssat_derivatives`,
  :func:`ssat_margin`; and every generated kernel by name: :func:`kernel_table`,
  :func:`call_kernel`.

Tachyon 3's own helpers and scenarios (``Environment``, ``Course``, ``simulate``, world
kinematics) are in :mod:`cbfgen.tachyon3`; ANYmal C's whole-body controller is in
:mod:`cbfgen.anymal`.

Errors from the Rust core raise :class:`CbfError` (a ``ValueError``) with its message.
"""

from . import anymal, tachyon3
from ._native import (
    HALF_EXTENT_RANGE,
    INPUT_SOURCES,
    MAX_COORDINATE,
    MAX_INPUT,
    MAX_INSTANCES,
    MAX_ITERATIONS,
    MAX_PRIORITY,
    MAX_TIME_LIMIT_US,
    PARAM_LIMIT,
    POLE_RANGE,
    SOLVERS,
    SSAT_ALPHA_RANGE,
    SSAT_VARIANTS,
    STATE_LIMIT,
    CbfError,
    EcbfFilter,
    FilterOutput,
    Params,
    Rows,
    System,
    call_kernel,
    kernel_table,
    ssat,
    ssat_derivatives,
    ssat_margin,
    systems,
)
from .plugins import LoadError, load

__all__ = [
    "anymal",
    "LoadError",
    "load",
    "HALF_EXTENT_RANGE",
    "INPUT_SOURCES",
    "MAX_COORDINATE",
    "MAX_INPUT",
    "MAX_INSTANCES",
    "MAX_ITERATIONS",
    "MAX_PRIORITY",
    "MAX_TIME_LIMIT_US",
    "PARAM_LIMIT",
    "POLE_RANGE",
    "SOLVERS",
    "SSAT_ALPHA_RANGE",
    "SSAT_VARIANTS",
    "STATE_LIMIT",
    "CbfError",
    "EcbfFilter",
    "FilterOutput",
    "Params",
    "Rows",
    "System",
    "call_kernel",
    "kernel_table",
    "ssat",
    "ssat_derivatives",
    "ssat_margin",
    "systems",
    "tachyon3",
]
