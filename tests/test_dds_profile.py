"""drs_ros.dds_profile: the Fast DDS profile drs's processes load. Which profile is used when,
and what it does: a participant with it is found by a newer one within its 0.5 s
announcement period, where Fast DDS's default (3 s) left ~40 % of the starts waiting 1.2-3.1 s."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET

import pytest
from node_support import domain_for, node_env

from drs_ros.dds_profile import PROFILE_FILE, PROFILE_VARIABLES, use_discovery_profile


def test_the_profile_is_named_when_no_other_is():
    env = {}
    assert use_discovery_profile(env) == PROFILE_FILE
    assert env == {"FASTRTPS_DEFAULT_PROFILES_FILE": str(PROFILE_FILE)}
    assert PROFILE_FILE.is_file()


@pytest.mark.parametrize("variable", PROFILE_VARIABLES)
def test_a_profile_the_user_names_wins(variable):
    env = {variable: "/etc/my_profile.xml"}
    assert use_discovery_profile(env) is None
    assert env == {variable: "/etc/my_profile.xml"}


@pytest.mark.parametrize(
    ("rmw", "named"),
    [("rmw_cyclonedds_cpp", False), ("rmw_fastrtps_cpp", True), ("rmw_fastrtps_dynamic_cpp", True)],
)
def test_another_middleware_gets_no_fast_dds_profile(rmw, named):
    env = {"RMW_IMPLEMENTATION": rmw}
    assert (use_discovery_profile(env) is not None) == named
    assert ("FASTRTPS_DEFAULT_PROFILES_FILE" in env) == named


def test_the_profile_is_fast_dds_xml_with_the_documented_periods():
    """The file parses, and holds the periods its docstring states (0.5 s, 20 x 50 ms)."""
    ns = {"f": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}
    root = ET.parse(PROFILE_FILE).getroot()
    participant = root.find("f:profiles/f:participant", ns)
    assert participant.get("is_default_profile") == "true"
    config = participant.find("f:rtps/f:builtin/f:discovery_config", ns)

    def seconds(node):
        return int(node.find("f:sec", ns).text) + int(node.find("f:nanosec", ns).text) * 1e-9

    assert seconds(config.find("f:leaseAnnouncement", ns)) == pytest.approx(0.5)
    initial = config.find("f:initialAnnouncements", ns)
    assert int(initial.find("f:count", ns).text) == 20
    assert seconds(initial.find("f:period", ns)) == pytest.approx(0.05)


#: A subscriber that has (or not) the profile, up until it is killed.
SUBSCRIBER = textwrap.dedent(
    """
    import sys, time
    if sys.argv[1] == "profile":
        from drs_ros.dds_profile import use_discovery_profile
        use_discovery_profile()
    import rclpy
    from std_msgs.msg import Float64
    rclpy.init()
    node = rclpy.create_node("profile_subscriber")
    node.create_subscription(Float64, "/profile_probe", lambda m: None, 10)
    print("ready", flush=True)
    while True:
        time.sleep(1.0)
    """
)

#: A publisher started after it, without the profile: seconds from its participant's creation
#: to its match with the subscriber.
PUBLISHER = textwrap.dedent(
    """
    import time
    import rclpy
    from std_msgs.msg import Float64
    rclpy.init()
    node = rclpy.create_node("profile_publisher")
    pub = node.create_publisher(Float64, "/profile_probe", 10)
    t0 = time.monotonic()
    while pub.get_subscription_count() < 1 and time.monotonic() - t0 < 20.0:
        time.sleep(0.005)
    print(time.monotonic() - t0, flush=True)
    """
)


@pytest.mark.ros
@pytest.mark.slow
def test_a_participant_with_the_profile_is_found_by_a_newer_one_within_its_period(
    tmp_path, request
):
    """8 publishers, one after the other, each find the subscriber within 2 s of their start
    (0.5 s announcements and the machine's load). Without the profile ~40 % of such starts took
    1.2-3.1 s, so that a profile that did not take effect passes 8 starts once in ~60."""
    env = node_env(tmp_path, domain_for(request.node.nodeid))
    for name in PROFILE_VARIABLES:
        env.pop(name, None)  # the publishers have Fast DDS's defaults, and so would the subscriber
    sub = subprocess.Popen(
        [sys.executable, "-c", SUBSCRIBER, "profile"], env=env, stdout=subprocess.PIPE, text=True
    )
    try:
        assert sub.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # its own start-up announcements are over
        found = []
        for _ in range(8):
            out = subprocess.run(
                [sys.executable, "-c", PUBLISHER],
                env=env,
                capture_output=True,
                text=True,
                timeout=60,
                check=True,
            )
            found.append(float(out.stdout.strip()))
    finally:
        sub.kill()
        sub.wait()
    assert max(found) < 2.0, found
