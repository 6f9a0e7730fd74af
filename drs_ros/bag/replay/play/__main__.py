"""``python -m drs_ros.bag.replay.play BAG``: ``drs-bag play`` without the dispatcher."""

import sys

from drs_ros.bag.replay.play.player import main

sys.exit(main())
