"""cbfgen: code-generated Exponential-CBF safety filters (Tachyon 3 style), from Python.

Everything here is the Rust crate's, through pyo3:

* the smooth SAT kernels: :func:`ssat`, :func:`ssat_derivatives`, :func:`ssat_margin`;
* every constraint family's rows at a state: :func:`joint_limits`, :func:`foot_height`,
  :func:`stability`, :func:`body_edge`, :func:`toe_edge`, :func:`foothold`, each returning
  ``(lie, lg_lf)`` with ``lie[i] = [h, L_f h, L_f^2 h]`` and ``lg_lf[i] = L_g L_f h``;
* the multi-layer example's time-varying row: :func:`sine_barrier`;
* the model: :func:`dynamics_f`, :func:`dynamics_g`, :func:`xdot`,
  :func:`world_kinematics`, :func:`standard_posture` and the layout constants;
* the safety filter: :class:`EcbfFilter`, :class:`Environment`, :class:`FilterOutput`;
* the scenarios: :class:`Course` for a loop of your own, :func:`simulate` for the Rust one.

Errors from the Rust core raise :class:`CbfError` (a ``ValueError``) with its message.
"""

from ._native import *  # noqa: F401,F403
from ._native import __all__ as _native_all

__all__ = list(_native_all)
