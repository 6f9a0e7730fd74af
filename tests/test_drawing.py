"""drs_ros.drawing: the moving drawings are the kinematics' points, arranged. Over configurations
across the working stroke, one at a time or several at once, each drawing joins the points it
names (piston A-B, link B-C, gap from R straight up to the height of T), the pins are the named
points in order, the flap is its outline closed, and the batch equals its rows drawn alone."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import kinematics as kin
from drs_ros.drawing import PIN_NAMES, moving_drawings, still_drawings


@settings(max_examples=40, deadline=None)
@given(fractions=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=4))
def test_moving_drawings_join_the_kinematics_points(params, fractions):
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(s_min + np.array(fractions) * (s_max - s_min), params)
    lines, pins, force_at = moving_drawings(q, params)
    for i, qi in enumerate(q):
        pt = {name: kin.point_positions(qi, params, (name,))[name] for name in (*PIN_NAMES, "P")}
        np.testing.assert_array_equal(lines["piston"][i], [pt["A"], pt["B"]])
        np.testing.assert_array_equal(lines["link"][i], [pt["B"], pt["C"]])
        np.testing.assert_array_equal(lines["gap"][i], [pt["R"], [pt["R"][0], pt["T"][1]]])
        np.testing.assert_array_equal(pins[i], [pt[name] for name in PIN_NAMES])
        np.testing.assert_array_equal(force_at[i], pt["P"])
        outline = kin.flap_outline(qi, params)
        np.testing.assert_array_equal(lines["flap"][i], [*outline, outline[0]])
        # drawn alone, a configuration gives its row of the batch
        one_lines, one_pins, one_at = moving_drawings(qi[None, :], params)
        for name, drawn in lines.items():
            np.testing.assert_array_equal(one_lines[name][0], drawn[i])
        np.testing.assert_array_equal(one_pins[0], pins[i])
        np.testing.assert_array_equal(one_at[0], force_at[i])


def test_the_flap_tip_is_on_the_drawn_outline_and_the_gap_is_the_models(params):
    """The drawn gap is the model's gap (an independent statement: kinematics.gap's closed form),
    and the pins' T lies on the flap's drawn outline."""
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(np.linspace(s_min, s_max, 7), params)
    lines, pins, _ = moving_drawings(q, params)
    gap = lines["gap"][:, 1, 1] - lines["gap"][:, 0, 1]
    np.testing.assert_allclose(gap, kin.gap(q, params), rtol=0, atol=1e-15)
    tip = pins[:, PIN_NAMES.index("T")]
    distance = np.linalg.norm(lines["flap"] - tip[:, None, :], axis=-1).min(axis=-1)
    assert np.all(distance < 1e-3)


def test_still_drawings_are_closed(params):
    for outline in still_drawings(params).values():
        np.testing.assert_array_equal(outline[0], outline[-1])
