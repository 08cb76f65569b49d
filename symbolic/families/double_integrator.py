"""The double integrator q'' = u under a moving lower bound: the multi-layer safety example.

State x = [q, q'], input u. The safe set is time-varying: q must stay above the sinusoid
s(t) = A sin(w t) + c, so

    h(x, t) = q - s(t).

A, w and c are runtime kernel arguments and t is a scalar input. The engine treats t as
a clock (t' = 1), so every Lie derivative carries the boundary's motion:

    L_f h   = q' - A w cos(w t)
    L_f^2 h = A w^2 sin(w t)           (the q'' part is the input's: L_g L_f h = 1)

The boundary is a let, so the clock's rate is taken through a named intermediate, the
same path a moving obstacle's pose would take.
"""

from __future__ import annotations

import symengine as se

from ..codegen.backends.rust.emitter import RawRust
from ..kernel import Kernel
from ..lie import LieEngine
from .rows import row_kernel, rust_str_array

STATE_NAMES = ("q", "qd")
INPUT_NAMES = ("u",)


def sine_barrier() -> Kernel:
    q, qd = se.symbols("x_q x_qd")
    f = [qd, se.Integer(0)]
    g = [[se.Integer(0)], [se.Integer(1)]]

    def build(k: Kernel, eng: LieEngine):
        amplitude = k.scalar_input("amplitude", "amplitude A of the boundary [m]")
        omega = k.scalar_input("omega", "angular frequency w of the boundary [rad/s]")
        offset = k.scalar_input("offset", "offset c of the boundary [m]")
        t = eng.time
        boundary = eng.let_("boundary", amplitude * se.sin(omega * t) + offset)
        return [("above_sine", q - boundary)]

    return row_kernel("sine_barrier", "The double integrator's position above the moving boundary "
                      "A sin(w t) + c: h = q - A sin(w t) - c, with the boundary's time derivatives.",
                      STATE_NAMES, [q, qd], f, g, build,
                      time_input=("t", "time t [s]"))


def kernels() -> list[Kernel | RawRust]:
    constants = RawRust(
        f"/// State layout of the double integrator.\n"
        f"pub const STATE_NAMES: [&str; {len(STATE_NAMES)}] = {rust_str_array(STATE_NAMES)};\n"
        f"/// Input layout of the double integrator.\n"
        f"pub const INPUT_NAMES: [&str; {len(INPUT_NAMES)}] = {rust_str_array(INPUT_NAMES)};\n")
    return [constants, sine_barrier()]


MODULE_DOC = """The double integrator q'' = u with the time-varying barrier h = q - A sin(w t) - c of the
multi-layer safety example, differentiated to its relative degree with the dh/dt terms.
See `symbolic/families/double_integrator.py`."""
