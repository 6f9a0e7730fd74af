"""``python -m drs_ros``: start the node (same as ``drs-node``)."""

from .node import run

run()
