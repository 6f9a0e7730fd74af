"""``python -m drs_ros.bag.play BAG``: ``drs-bag play`` without the dispatcher."""

import sys

from .player import main

sys.exit(main())
