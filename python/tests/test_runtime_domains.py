"""The symbolic stage checks a spec against the runtime's domains when it generates, so that
a spec fails then rather than when its filter is built. Those bounds are written in Python
for the build step; this test holds them to the built module's, which are the runtime's
own (src/filter/settings.rs, src/system.rs, src/ssat.rs, src/geometry.rs)."""

import cbfgen

from symbolic import spec


def test_spec_bounds_are_the_runtimes():
    assert spec.MAX_INPUT == cbfgen.MAX_INPUT
    assert spec.MAX_INSTANCES == cbfgen.MAX_INSTANCES
    assert spec.POLE_RANGE == cbfgen.POLE_RANGE
    assert spec.MAX_PRIORITY == cbfgen.MAX_PRIORITY


def test_geometry_bounds_are_the_runtimes():
    # What a model file is checked against (Tachyon 3's smoothing sharpness, body size).
    assert spec.SSAT_ALPHA_RANGE == cbfgen.SSAT_ALPHA_RANGE
    assert spec.HALF_EXTENT_RANGE == cbfgen.HALF_EXTENT_RANGE
    assert spec.INPUT_LIMIT_RANGE == (0.0, cbfgen.MAX_INPUT)
