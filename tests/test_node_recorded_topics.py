"""What the bag records beside the node's publications, against a recorder that notes each call:
every command typed as the intake decodes it, the service's events, the stack's topics and
/parameter_events, registered before the node's parameters are written there, at the time read
after the registrations."""

from __future__ import annotations

from rcl_interfaces.msg import ParameterEvent
from std_srvs.srv import SetBool

from drs_ros import commands
from drs_ros.node.intake import COMMANDS
from drs_ros.node.recorded_topics import PARAMETER_EVENTS, register_recorded_topics


class _Recorder:
    def __init__(self) -> None:
        self.calls = []

    def register_topic(self, topic, msg_type, qos=None) -> None:
        self.calls.append(("register", topic, msg_type, qos.depth))

    def write(self, topic, message, now_ns) -> None:
        self.calls.append(("write", topic, message, now_ns))


def test_every_topic_registered_before_the_parameters_are_written() -> None:
    recorder = _Recorder()
    published = [("/joint_states", "JointState", type("Q", (), {"depth": 7})())]
    stack = [("/tf", "TFMessage", type("Q", (), {"depth": 3})())]
    command_topics = {key: f"/drs/{key}" for key in COMMANDS}
    clock = iter([5, 6])
    register_recorded_topics(
        recorder,
        published,
        command_topics,
        "/drs/drs/_service_event",
        stack,
        lambda now: ("parameters at", now),
        lambda: next(clock),
    )
    depth = commands.COMMAND_QOS_DEPTH
    expected = [("register", "/joint_states", "JointState", 7)]
    expected += [("register", f"/drs/{key}", COMMANDS[key], depth) for key in COMMANDS]
    expected += [
        ("register", "/drs/drs/_service_event", SetBool.Event, 100),
        ("register", "/tf", "TFMessage", 3),
        ("register", PARAMETER_EVENTS, ParameterEvent, 1000),
        ("write", PARAMETER_EVENTS, ("parameters at", 5), 5),
    ]
    assert recorder.calls == expected
