"""config/foxglove-layout.json: a Foxglove layout whose 3D panel shows the node's markers in
drs_base and whose Plot panels show stroke, gap and piston force, naming only topics the node
publishes, with message paths whose fields exist in the recorded message types."""

from __future__ import annotations

import json
import re
from pathlib import Path

from ros_support import require_module

from drs_ros.names import DEFAULT_TOPICS

REPO = Path(__file__).resolve().parents[1]
LAYOUT = REPO / "config" / "foxglove-layout.json"
EXAMPLE_BAG = REPO / "bags" / "example"
#: The node's MarkerArray topic (``~/markers``), beside the names in drs_ros.names.
MARKERS = "/drs/markers"
#: What the plots must show: message path -> what it is.
PLOTS = {
    "/joint_states.position[0]": "stroke",
    "/drs/flap_gap.data": "gap",
    "/drs/piston_force.data": "piston force",
}
#: A message path: a topic, then fields and indices (Foxglove's message path syntax, subset).
MESSAGE_PATH = re.compile(r"^(?P<topic>/[A-Za-z0-9_/]+?)(?P<fields>(\.[A-Za-z0-9_]+(\[\d+\])?)*)$")


def load_layout() -> dict:
    return json.loads(LAYOUT.read_text())


def panels_of_type(layout: dict, kind: str) -> dict[str, dict]:
    return {pid: cfg for pid, cfg in layout["configById"].items() if pid.split("!")[0] == kind}


def panel_ids_in_tree(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    return panel_ids_in_tree(node["first"]) + panel_ids_in_tree(node["second"])


def strings_in(value) -> list[str]:
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return [s for k, v in value.items() for s in [k, *strings_in(v)]]
    if isinstance(value, list):
        return [s for v in value for s in strings_in(v)]
    return []


def test_layout_structure():
    layout = load_layout()
    assert set(layout) >= {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"}
    in_tree = panel_ids_in_tree(layout["layout"])
    assert sorted(in_tree) == sorted(layout["configById"]), "every panel shown exactly once"
    for node_id in in_tree:
        assert re.fullmatch(r"[A-Za-z0-9]+![A-Za-z0-9]+", node_id), node_id


def test_3d_panel_shows_the_markers_in_drs_base():
    (threed,) = panels_of_type(load_layout(), "3D").values()
    assert threed["followTf"] == "drs_base"
    assert threed["followMode"] in ("follow-pose", "follow-position", "follow-none")
    assert threed["topics"] == {MARKERS: {"visible": True}}
    camera = threed["cameraState"]
    # Looking down -z onto the z = 0 plane of the markers, x to the right and y up on screen.
    assert camera["phi"] == 0 and camera["thetaOffset"] == 0 and camera["perspective"] is False
    grids = [g for g in threed["layers"].values() if g["layerId"] == "foxglove.Grid"]
    assert [g["frameId"] for g in grids] == ["drs_base"]


def test_plots_show_stroke_gap_and_force():
    plots = panels_of_type(load_layout(), "Plot")
    paths = [p for cfg in plots.values() for p in cfg["paths"]]
    assert sorted(p["value"] for p in paths) == sorted(PLOTS)
    for path in paths:
        assert path["enabled"] is True
        assert path["timestampMethod"] in ("receiveTime", "headerStamp")
        assert path["label"] == PLOTS[path["value"]]
    for cfg in plots.values():
        assert cfg["xAxisVal"] == "timestamp"


def test_every_topic_named_is_published_by_the_node():
    published = set(DEFAULT_TOPICS.values()) | {MARKERS}
    named = set()
    for text in strings_in(load_layout()):
        if text.startswith("/"):
            match = MESSAGE_PATH.fullmatch(text)
            assert match, f"{text!r} is not a topic or message path"
            named.add(match["topic"])
    plotted = {MESSAGE_PATH.fullmatch(p)["topic"] for p in PLOTS}
    assert named == plotted | {MARKERS}, named
    assert named <= published, named - published


def test_plot_fields_exist_in_the_recorded_message_types():
    """The field each plot reads exists in the type the example bag records on that topic (types
    and definitions read by rosbags, not by our code)."""
    highlevel = require_module("rosbags.highlevel")
    for path in PLOTS:
        match = MESSAGE_PATH.fullmatch(path)
        (field, *rest) = [re.sub(r"\[\d+\]$", "", f) for f in match["fields"].split(".")[1:]]
        assert not rest, path
        with highlevel.AnyReader([EXAMPLE_BAG]) as reader:
            (msgtype,) = {c.msgtype for c in reader.connections if c.topic == match["topic"]}
            names = [f[0] for f in reader.typestore.get_msgdef(msgtype).fields]
        assert field in names, (path, msgtype, names)
