"""The two processes around the node in ``node_vs_floor.py``: the floor (a bare process that
publishes the node's per-tick messages and nothing else) and the listener (a subscriber to the
node's state topics, the same process beside the floor and beside the node).

The floor takes its topics, types, QoS and bytes from the node's own code: it makes the node's
:class:`drs_ros.node.publishers.StatePublishers` on a bare node named as the node
(``drs``), asks it for the messages of the seed's first state (``state_messages``, which also asks
DDS which topics have a subscriber, as the node does) and, at each deadline of the node's loop
(``deadline_floor.DeadlineLoop``, under the node's ``apply_tick_policy``), hands DDS the messages
of the listened topics as those bytes: no model, no packing, no recording, no executor.

Usage (by ``node_vs_floor.py``): ``python benchmarks/floor_process.py floor RATE SECONDS
ROLE...`` and ``python benchmarks/floor_process.py listener ROLE...``; each prints one JSON line.
"""

from __future__ import annotations

import json
import sys
import time

from deadline_floor import publish_on_deadlines  # the node's loop, counted as the node counts

#: The node's name (its ``~/`` topics resolve under it) and the state roles a listener may take.
NODE_NAME = "drs"
STATE_ROLES = ("joint_states", "piston_force", "flap_gap", "piston_acceleration")
#: Seconds the floor waits for the listener to match before it publishes anyway.
MATCH_TIMEOUT_S = 20.0


def state_publishers(node):
    """The node's state publishers made on ``node`` with the node's defaults (its parameters'
    table), and the actuator whose first state they publish."""
    from drs_model.actuator import ActuatorSim
    from drs_model.params import DRSParams
    from drs_ros.names import DEFAULT_JOINT_NAMES, NODE_TOPICS
    from drs_ros.node.parameters import NODE_PARAMETERS
    from drs_ros.node.publishers import StatePublishers

    defaults = {name: default for name, default, *_ in NODE_PARAMETERS}
    params = DRSParams()
    sim = ActuatorSim(params, 1.0 / defaults["physics_rate_hz"])
    outputs = StatePublishers(
        node,
        joint_states_topic=NODE_TOPICS["joint_states"],
        joint_names=list(DEFAULT_JOINT_NAMES),
        frame_id=defaults["frame_id"],
        params=params,
        s_min=sim.s_min,
        markers_period=1.0 / defaults["markers_rate_hz"],
        hydraulic=False,
    )
    return outputs, sim


def state_topics(roles: list[str]) -> list[tuple[str, type, int]]:
    """``(topic, message type, QoS depth)`` of the node's state ``roles``, from its own publishers
    (made in a context of their own and destroyed)."""
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx)
    try:
        node = rclpy.create_node(NODE_NAME, context=ctx)
        outputs, _sim = state_publishers(node)
        names = outputs.topic_names()
        offered = {topic: (t, qos.depth) for topic, t, qos in outputs.recorded_topics()}
        out = []
        for role in roles:
            msg_type, depth = offered[names[role]]
            out.append((names[role], msg_type, depth))
        outputs.destroy(node)
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
    return out


def floor(
    rate_hz: float, duration_s: float, roles: list[str], warm_s: float = 1.0, tick_cpu: int = -1
) -> dict:
    """The floor's loop: its CPU share over ``duration_s`` [s] (after ``warm_s`` of warm-up, once
    the listener matched the topics of ``roles``) and its deadlines; its thread on CPU
    ``tick_cpu`` (-1: any), as the node's with ``tick_cpu``."""
    import rclpy

    from drs_ros.dds_profile import use_discovery_profile

    use_discovery_profile()  # the node's own participant settings
    rclpy.init()
    node = rclpy.create_node(NODE_NAME)
    outputs, sim = state_publishers(node)
    names = outputs.topic_names()
    wanted = [
        pub for pub in outputs.state_publishers if pub.topic_name in {names[r] for r in roles}
    ]
    give_up = time.monotonic() + MATCH_TIMEOUT_S
    while time.monotonic() < give_up and any(p.get_subscription_count() < 1 for p in wanted):
        time.sleep(0.05)
    # tick 1: the node's own listener check; the messages the node would hand DDS this tick
    out = outputs.state_messages(sim, sim.state, time.time_ns(), None, 1, recording=False)
    pubs = [(pub, data) for pub, data in out if outputs.listened[pub]]
    cpu, wall, loop, policy = publish_on_deadlines(pubs, rate_hz, warm_s, duration_s, tick_cpu)
    published = {pub.topic_name: len(data) for pub, data in pubs}
    outputs.destroy(node)
    node.destroy_node()
    rclpy.shutdown()
    return {
        "policy": policy,
        "cpu_share": cpu / wall,
        "published_bytes": published,
        **loop.counts(),
    }


def listener(roles: list[str]) -> None:
    """Subscribe to the node's state ``roles`` at the node's QoS and count what arrives until
    SIGTERM or SIGINT; print the counts as JSON. With drs's Fast DDS profile (announced every
    0.5 s): started before the node, with Fast DDS's 3 s the node matched it up to 3 s after
    its start, past the 2 s warm-up, in about 4 runs of 10, and the measured window began with
    the node handing its joint states to no one (2,533 of ~3,250 received in such a run)."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import QoSProfile

    from drs_ros.dds_profile import use_discovery_profile

    use_discovery_profile()  # before state_topics' context: the first participant of the process
    topics = state_topics(roles)
    counts = {topic: 0 for topic, *_ in topics}
    rclpy.init()
    node = rclpy.create_node("floor_listener")

    def counter(topic):
        def count(_data):
            counts[topic] += 1

        return count

    for topic, msg_type, depth in topics:
        node.create_subscription(msg_type, topic, counter(topic), QoSProfile(depth=depth), raw=True)
    print(json.dumps({"ready": [t for t, *_ in topics]}), flush=True)
    try:
        rclpy.spin(node)  # rclpy's own handlers (SIGINT and SIGTERM) end the spin
    except (ExternalShutdownException, KeyboardInterrupt):
        pass
    print(json.dumps({"received": counts}), flush=True)


def main(argv: list[str]) -> int:
    if argv[0] == "floor":  # floor RATE DURATION [--tick-cpu N] ROLE...
        roles, tick_cpu = argv[3:], -1
        if roles[:1] == ["--tick-cpu"]:
            roles, tick_cpu = roles[2:], int(roles[1])
        result = floor(float(argv[1]), float(argv[2]), roles, tick_cpu=tick_cpu)
        print(json.dumps(result), flush=True)
    elif argv[0] == "listener":
        listener(argv[1:])
    else:
        raise SystemExit(f"role must be floor or listener, got {argv[0]!r}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
