"""Shared fixtures. Model tests never import rclpy."""

from __future__ import annotations

import os

import pytest

# Anything that starts rclpy in this process stays on loopback and checks field types.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_PYTHON_CHECK_FIELDS", "1")

from node_support import ros_context  # noqa: E402, F401 - fixture for the node tests

from drs_model.params import DRSParams  # noqa: E402


@pytest.fixture(scope="session")
def params() -> DRSParams:
    return DRSParams()
