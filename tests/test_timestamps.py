"""drs_ros.timestamps: integer nanoseconds <-> (sec, nanosec) <-> seconds, against independent
references: rclpy's own Time / Duration, exact fractions, and the module's round trips."""

from __future__ import annotations

from fractions import Fraction
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

from drs_ros.timestamps import (
    NS_PER_S,
    ns_from_parts,
    ns_from_seconds,
    ns_of,
    seconds_from_ns,
    set_ns,
    split_ns,
)

#: An epoch stamp of 2026 and beyond, and durations either side of zero [ns].
ANY_NS = st.integers(-(2**62), 2**62)
EPOCH_NS = st.integers(1_700_000_000 * NS_PER_S, 2_100_000_000 * NS_PER_S)


@given(ANY_NS)
def test_split_is_exact_with_nanosec_in_range(ns):
    sec, nanosec = split_ns(ns)
    assert 0 <= nanosec < NS_PER_S
    assert ns_from_parts(sec, nanosec) == ns
    assert ns_of(set_ns(SimpleNamespace(), ns)) == ns


@settings(deadline=None)  # the first example imports rclpy
@given(st.integers(-(2**40), 2**40))
def test_split_is_rclpys(ns):
    """The fields rclpy writes for a Duration (negative too) and a Time."""
    require_rclpy()
    from rclpy.duration import Duration
    from rclpy.time import Time

    msg = Duration(nanoseconds=ns).to_msg()
    assert split_ns(ns) == (msg.sec, msg.nanosec)
    if ns >= 0:
        t = Time(nanoseconds=ns).to_msg()
        assert split_ns(ns) == (t.sec, t.nanosec)


@given(st.one_of(ANY_NS, EPOCH_NS))
def test_seconds_are_the_nearest_float(ns):
    assert seconds_from_ns(ns) == float(Fraction(ns, NS_PER_S))


@given(st.integers(-(2**51), 2**51))
def test_seconds_and_back_is_exact_within_26_days(ns):
    assert ns_from_seconds(seconds_from_ns(ns)) == ns


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_ns_of_seconds_is_the_nearest_but_for_the_products_rounding(seconds):
    """Within half a nanosecond of the exact value, plus the rounding of ``seconds * 1e9`` (half
    an ulp: 2**-53 relative)."""
    exact = Fraction(seconds) * NS_PER_S
    assert abs(ns_from_seconds(seconds) - exact) <= Fraction(1, 2) + abs(exact) / 2**53


def test_a_difference_just_below_a_whole_second():
    """``2.3 - 1.3`` s is 0.9999999999999998 s as floats: to nanoseconds first, then the
    difference, is exactly one second (a float split gave 0 s and 0 ns)."""
    assert 2.3 - 1.3 < 1.0
    assert split_ns(ns_from_seconds(2.3) - ns_from_seconds(1.3)) == (1, 0)
    assert split_ns(ns_from_seconds(2.3 - 1.3)) == (1, 0)


def test_ns_of_a_message():
    require_rclpy()
    from builtin_interfaces.msg import Duration, Time

    assert ns_of(Time(sec=3, nanosec=7)) == 3_000_000_007
    d = set_ns(Duration(), -1)
    assert (d.sec, d.nanosec) == (-1, 999_999_999)
    with pytest.raises(ValueError):
        ns_from_seconds(float("nan"))
