"""Re-running a bag: ``drs-bag resimulate`` (the recorded commands in the model) and
``drs-bag play`` (the bag published onto ROS 2 topics)."""
