"""The ``drs-bag`` tools: info, check, recover, play, resimulate (named after ``ros2 bag``)."""
