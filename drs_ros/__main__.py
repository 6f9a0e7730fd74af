"""``python -m drs_ros``: start the node (same as ``drs-node``)."""

import sys

from .node import main

sys.exit(main())
