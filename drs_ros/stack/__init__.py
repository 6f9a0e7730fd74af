"""What the node offers a vehicle stack: ``layer`` (:class:`~drs_ros.stack.layer.StackLayer`, the
one object the node drives, and the parameters of these features), ``description`` (the URDF
and its ros2_control block), ``tf_tree`` (``/tf``, ``/tf_static``, ``/robot_description``),
``follow_trajectory`` (joint_trajectory_controller's ``~/follow_joint_trajectory`` action) and
``joint_commands`` (ros2_control's JointState commands, read by joint name).

Nothing is re-exported here: :mod:`drs_ros.commands` reads :mod:`.joint_commands`, and
:mod:`.follow_trajectory` builds on :mod:`drs_ros.commands`, so importing the layer here would
make the two packages import each other.
"""
