"""The interface packages built from source by ``interfaces/build.py`` (no PyPI wheel ships them):
``tf2_msgs`` and ``control_msgs`` carry upstream Jazzy's definitions byte for byte, their RIHS01
type hashes (computed by rosidl when they were built) equal the ones ``rosbags`` computes on its
own from the definitions, and rclpy uses them: the node publishes TFMessage and serves
FollowJointTrajectory with them."""

from __future__ import annotations

import hashlib
import json
import re
import sys
from pathlib import Path

import pytest
from ros_support import require_module

REPO = Path(__file__).resolve().parents[1]
INTERFACES = REPO / "interfaces"

#: SHA-256 of the upstream files (ros2/geometry2 branch jazzy 646342c6, tf2_msgs 0.36.4;
#: ros-controls/control_msgs branch jazzy f901df26, 5.8.0), read from the upstream repositories.
UPSTREAM_SHA256 = {
    "tf2_msgs/msg/TFMessage.msg":
        "f3fca610a59b31ee4c7b740522ecdd0fd8c76002170088111409e4df513f1dfc",
    "control_msgs/action/FollowJointTrajectory.action":
        "31a124428ee490da22c15cc70a9ac2c89d07bbbba7d3bf370ca7596b229cb9f0",
    "control_msgs/msg/JointTolerance.msg":
        "8208718f17c1b1feb9418c3ed7ca73d029566cbf298ecda819c9e0b78cb379d3",
    "control_msgs/msg/JointComponentTolerance.msg":
        "6b09271d0f74e0a3a701f3ddb997b0ad4a588bdd9ab7d7899ddc70063ba924dd",
}  # fmt: skip
#: rosbags' own Jazzy typestore holds tf2_msgs; this is the hash it gives TFMessage (and the one
#: docs/ros.md quotes).
TFMESSAGE_RIHS01 = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
ACTION = "control_msgs/action/FollowJointTrajectory"


def test_definitions_are_upstreams_byte_for_byte():
    for rel, digest in UPSTREAM_SHA256.items():
        assert hashlib.sha256((INTERFACES / rel).read_bytes()).hexdigest() == digest, rel


def installed_hashes(package: str) -> dict[str, str]:
    """Type name -> RIHS01 of every type described under ``share/<package>`` of this venv."""
    share = Path(sys.prefix) / "share" / package
    if not share.is_dir():
        pytest.fail(f"{share} missing: run `make venv` (interfaces/build.py builds {package})")
    out = {}
    for path in share.glob("*/*.json"):
        for entry in json.loads(path.read_text())["type_hashes"]:
            out[entry["type_name"]] = entry["hash_string"]
    return out


def action_definitions(text: str) -> dict[str, str]:
    """Every type rosidl derives from ``FollowJointTrajectory.action``, as message texts: the
    goal, result and feedback, the two services' requests, responses and events, the services,
    the feedback message and the action itself (rosidl's action and service rules, REP 2011)."""
    goal, result, feedback = text.split("\n---\n")
    # rosidl resolves a bare type name of an .action file in the package's msg/ (rosbags would
    # look in action/): name the package's messages in full
    for name in ("JointTolerance", "JointComponentTolerance"):
        goal = re.sub(rf"^{name}\[", f"control_msgs/msg/{name}[", goal, flags=re.M)
    a = ACTION
    uuid = "unique_identifier_msgs/UUID goal_id\n"
    defs = {
        f"{a}_Goal": goal,
        f"{a}_Result": result,
        f"{a}_Feedback": feedback,
        f"{a}_SendGoal_Request": f"{uuid}{a}_Goal goal\n",
        f"{a}_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
        f"{a}_GetResult_Request": uuid,
        f"{a}_GetResult_Response": f"int8 status\n{a}_Result result\n",
        f"{a}_FeedbackMessage": f"{uuid}{a}_Feedback feedback\n",
    }
    for srv in ("SendGoal", "GetResult"):
        s = f"{a}_{srv}"
        defs[f"{s}_Event"] = (
            f"service_msgs/ServiceEventInfo info\n{s}_Request[<=1] request\n"
            f"{s}_Response[<=1] response\n"
        )
        defs[s] = (
            f"{s}_Request request_message\n{s}_Response response_message\n{s}_Event event_message\n"
        )
    defs[a] = (
        f"{a}_Goal goal\n{a}_Result result\n{a}_Feedback feedback\n"
        f"{a}_SendGoal send_goal_service\n{a}_GetResult get_result_service\n"
        f"{a}_FeedbackMessage feedback_message\n"
    )
    return defs


def rosbags_jazzy():
    typesys = require_module("rosbags.typesys")
    return typesys, typesys.get_typestore(typesys.Stores.ROS2_JAZZY)


def test_tfmessage_hash_is_upstreams():
    _typesys, store = rosbags_jazzy()
    assert store.hash_rihs01("tf2_msgs/msg/TFMessage") == TFMESSAGE_RIHS01
    assert installed_hashes("tf2_msgs")["tf2_msgs/msg/TFMessage"] == TFMESSAGE_RIHS01


def test_control_msgs_hashes_equal_rosbags_from_the_upstream_text():
    typesys, store = rosbags_jazzy()
    # The service events hold service_msgs/ServiceEventInfo, whose `char[16] client_gid` rosidl
    # turns into uint8[16] (ROS 2: char is uint8); rosbags 0.11 keeps char, a type of its own, so
    # its hash differs from the wheel's. Registered in its IDL form, it gives the wheel's hash.
    info_name = "service_msgs/msg/ServiceEventInfo"
    info_text = (Path(sys.prefix) / "share/service_msgs/msg/ServiceEventInfo.msg").read_text()
    jazzy, store = store, typesys.get_typestore(typesys.Stores.EMPTY)
    store.register({k: v for k, v in jazzy.fielddefs.items() if k != info_name})
    idl_form = info_text.replace("char[16]", "uint8[16]")
    store.register(typesys.get_types_from_msg(idl_form, info_name))
    assert store.hash_rihs01(info_name) == installed_hashes("service_msgs")[info_name]
    types = {}
    for name in ("JointTolerance", "JointComponentTolerance"):
        text = (INTERFACES / "control_msgs" / "msg" / f"{name}.msg").read_text()
        types.update(typesys.get_types_from_msg(text, f"control_msgs/msg/{name}"))
    action = (INTERFACES / "control_msgs" / "action" / "FollowJointTrajectory.action").read_text()
    for name, text in action_definitions(action).items():
        types.update(typesys.get_types_from_msg(text, name))
    store.register(types)
    built = installed_hashes("control_msgs")
    expected = {name: store.hash_rihs01(name) for name in types}
    assert set(built) >= set(expected), set(expected) - set(built)
    mismatched = {n: (built[n], h) for n, h in expected.items() if built[n] != h}
    assert not mismatched, mismatched
    assert len(expected) == 15  # 2 messages + 13 types of the action


def test_built_types_import_and_name_themselves_as_upstream():
    require_module("rclpy")
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTolerance
    from tf2_msgs.msg import TFMessage

    from drs_ros.recording import msgdefs

    assert msgdefs.type_name(TFMessage) == "tf2_msgs/msg/TFMessage"
    assert msgdefs.type_name(JointTolerance) == "control_msgs/msg/JointTolerance"
    assert (
        msgdefs.type_hash(JointTolerance)
        == installed_hashes("control_msgs")["control_msgs/msg/JointTolerance"]
    )
    assert msgdefs.type_hash(TFMessage) == TFMESSAGE_RIHS01
    result = FollowJointTrajectory.Result
    assert (
        result.SUCCESSFUL,
        result.INVALID_GOAL,
        result.INVALID_JOINTS,
        result.OLD_HEADER_TIMESTAMP,
        result.PATH_TOLERANCE_VIOLATED,
        result.GOAL_TOLERANCE_VIOLATED,
    ) == (0, -1, -2, -3, -4, -5)
