"""The node's simulation clock (drs_ros.node.tick.SimulationClock), alone: no node, no rclpy.
The node's tick as a whole is exercised by the node tests (test_node*.py)."""

from __future__ import annotations

from drs_ros.node.tick import CLOCK_JUMP_THRESHOLD_S, SimulationClock

MS = 1_000_000  # ns


def test_origin_makes_stamps_follow_simulated_time():
    """Node time ``now`` at simulated time 0.25 s puts the origin 0.25 s before ``now``, and the
    steps due at a later node time are the simulated time between, in steps."""
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    clock.start(10_000 * MS, 0.25)
    assert clock.t0_ns == 9_750 * MS
    assert clock.steps_due(10_000 * MS + 4 * MS, 0.25, 1e-3) == 4
    assert clock.steps_due(10_000 * MS + 4 * MS - 1, 0.25, 1e-3) == 3
    # a state's stamp is the origin plus its simulated time; none before an origin
    assert clock.stamp_ns(0.254) == 10_004 * MS
    assert SimulationClock(wall_clock=True, publish_period_ns=4 * MS).stamp_ns(0.25) is None


def test_a_tick_more_than_a_period_and_a_half_late_on_the_steady_clock_is_a_missed_deadline():
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    assert clock.since_last_if_late(123) is None  # no tick yet
    clock.ticked(0, 0)
    assert clock.since_last_if_late(6 * MS) is None
    assert clock.since_last_if_late(6 * MS + 1) == 6 * MS + 1


def test_under_clock_no_tick_is_late():
    """``ros2 bag play --clock`` publishes /clock at 40 Hz: the ticks follow its messages, 25 ms
    of node time and of steady time apart, and none is a missed deadline."""
    clock = SimulationClock(wall_clock=False, publish_period_ns=4 * MS)
    clock.start(100 * MS, 0.0)
    mono = 0
    for k in range(40):
        now, mono = 100 * MS + 25 * MS * k, mono + 25 * MS
        assert clock.jump(now, mono) == 0
        assert clock.since_last_if_late(mono) is None
        clock.ticked(now, mono)


def test_a_wall_clock_step_moves_the_origin_by_the_step_and_is_no_missed_deadline():
    """The wall clock stepped forward 5 s between two ticks 4 ms apart on the steady clock: the
    origin moves by the 5 s (the simulation goes on from its state), and the tick is not late."""
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    clock.start(1_000 * MS, 0.0)
    clock.ticked(1_000 * MS, 50 * MS)
    jump = clock.jump(1_000 * MS + 5_000 * MS + 4 * MS, 54 * MS)
    assert jump == 5_000 * MS
    assert clock.t0_ns == 6_000 * MS
    assert clock.since_last_if_late(54 * MS) is None


def test_a_drift_below_the_threshold_is_no_jump():
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    clock.start(0, 0.0)
    clock.ticked(0, 0)
    below = round(CLOCK_JUMP_THRESHOLD_S * 1e9) - 1
    assert clock.jump(4 * MS + below, 4 * MS) == 0
    assert clock.t0_ns == 0


def test_sim_time_may_run_at_any_rate_but_a_step_back_is_a_jump():
    """Under /clock a long gap forward is a fast clock, not a jump; going back is."""
    clock = SimulationClock(wall_clock=False, publish_period_ns=4 * MS)
    clock.start(100 * MS, 0.0)
    clock.ticked(100 * MS, 0)
    assert clock.jump(10_000 * MS, 1) == 0
    clock.ticked(10_000 * MS, 1)
    assert clock.jump(2_000 * MS, 2) == -8_000 * MS
    assert clock.t0_ns == 100 * MS - 8_000 * MS


def test_a_pause_forgets_the_origin_and_the_last_tick():
    """Deactivated, the time away is neither simulated nor a missed deadline."""
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    clock.start(0, 0.0)
    clock.ticked(0, 0)
    clock.pause()
    assert clock.t0_ns is None
    assert clock.stamp_ns(1.0) is None
    assert clock.since_last_if_late(60_000 * MS) is None
    assert clock.jump(60_000 * MS, 5) == 0


def test_dropped_steps_move_the_origin_on():
    clock = SimulationClock(wall_clock=True, publish_period_ns=4 * MS)
    clock.start(0, 0.0)
    clock.drop(300, 1e-3)
    assert clock.t0_ns == 300 * MS
    assert clock.steps_due(500 * MS, 0.0, 1e-3) == 200
