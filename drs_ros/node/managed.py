"""The DRS node as a ROS 2 managed (lifecycle) node: ``drs-node --managed``."""

from __future__ import annotations

from rclpy.exceptions import ParameterException
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn

from drs_model.errors import DRSError

from ..errors import DRSRosError
from .adapter import DRSNode


class ManagedDRSNode(LifecycleNodeMixin, DRSNode):
    """The DRS node as a ROS 2 managed (lifecycle) node: ``drs-node --managed``.

    It starts unconfigured; a lifecycle manager drives it over the standard ``~/change_state``
    and ``~/get_state`` services: configure (validate the parameters, open the recorders),
    activate (subscriptions, service, timers), deactivate (hold, publish nothing), cleanup
    (finish the recordings), shutdown. A transition that fails logs the reason and returns
    FAILURE, as the lifecycle design says; the node stays in the state it was in, and the reason
    is kept in ``refused`` (``drs-node`` names each at the stop, docs/cli.md).

    Each configure records anew (:func:`~drs_ros.node.recordings.cycle_path`): the first to
    ``bag_path`` and ``rrd_path``, the n-th later one to those names with ``_n`` appended.
    """

    def __init__(self, **kwargs) -> None:
        #: The transitions that failed, each ``'NAME refused: reason'``, in order.
        self.refused: list[str] = []
        DRSNode.__init__(self, managed=True, **kwargs)
        LifecycleNodeMixin.__init__(self, enable_communication_interface=True)

    def _transition(self, name: str, action) -> TransitionCallbackReturn:
        try:
            action()
        except (DRSError, DRSRosError, ParameterException) as exc:
            self.get_logger().error(f"{name} failed: {exc}")
            self.refused.append(f"{name} refused: {exc}")
            if name == "configure":
                self.recordings.discard()
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("configure", self.configure)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("activate", self.activate)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("deactivate", self.deactivate)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("cleanup", self.cleanup)

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("shutdown", self.cleanup if self.configured else lambda: None)

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("error", self.cleanup if self.configured else lambda: None)


__all__ = ["ManagedDRSNode"]
