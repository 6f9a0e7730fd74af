"""The topics the node's bag records beside its publications, registered with their types and
QoS before the first message: the commands as received (raw, recorded as they arrived), the
``~/drs`` service's introspection events and ``/parameter_events``, whose first message is the
node's parameters at configure (so that a bag re-runs deterministically).
"""

from __future__ import annotations

from rcl_interfaces.msg import ParameterEvent
from rclpy.qos import QoSProfile
from std_srvs.srv import SetBool

from .. import commands
from .intake import COMMANDS

#: The topic of the parameter events, as rosbag2 records it.
PARAMETER_EVENTS = "/parameter_events"


def register_recorded_topics(
    recorder, published, command_topics, service_event_topic, stack_topics, parameter_event, now_ns
) -> None:
    """Register with ``recorder`` (the bag's, ``NodeRecordings.recorder``) the node's
    ``published`` topics and the stack's ``stack_topics`` (each ``(topic, type, qos)``), the
    commands (``command_topics``: a key of :data:`~.intake.COMMANDS` -> its resolved topic),
    ``service_event_topic`` and ``/parameter_events``; then write ``parameter_event(now)`` (a
    ParameterEvent message of the node's parameters) there, at ``now = now_ns()`` [ns]."""
    register = recorder.register_topic
    for topic, msg_type, qos in published:
        register(topic, msg_type, qos=qos)
    for key, topic in command_topics.items():
        register(topic, COMMANDS[key], qos=QoSProfile(depth=commands.COMMAND_QOS_DEPTH))
    register(service_event_topic, SetBool.Event, qos=QoSProfile(depth=100))
    for topic, msg_type, qos in stack_topics:
        register(topic, msg_type, qos=qos)
    register(PARAMETER_EVENTS, ParameterEvent, qos=QoSProfile(depth=1000))
    now = now_ns()
    recorder.write(PARAMETER_EVENTS, parameter_event(now), now)


__all__ = ["PARAMETER_EVENTS", "register_recorded_topics"]
