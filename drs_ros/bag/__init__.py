"""The ``drs-bag`` command family: work with rosbag2 MCAP bags (play, ...)."""
