"""drs_ros.client: a ``~/drs`` call left unanswered is sent again, so that a request the node
answered into the void (received before it had discovered the client's reply reader: a ROS 2
service is two topics discovered apart) does not leave the caller waiting for nothing."""

from __future__ import annotations

import threading
import time

from node_support import domain_for
from ros_support import require_rclpy


def test_an_unanswered_call_is_sent_again(request):
    """A server whose first request never gets its answer back in time (its callback holds it
    for 20 s; the server answers others meanwhile): the client's call is answered by the
    second request, sent after RESEND_S, within a few seconds instead of 20, and the server
    saw the request twice, the same both times."""
    require_rclpy()
    import rclpy
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from std_srvs.srv import SetBool

    from drs_ros.client import RESEND_S, DRSClient

    domain = domain_for(request.node.nodeid)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("drs", context=context)
    seen, release, first_done = [], threading.Event(), threading.Event()

    def answer(req, res):
        seen.append(req.data)
        res.success, res.message = True, f"request {len(seen)}"
        if len(seen) == 1:
            release.wait(20.0)  # the first answer comes back too late
            first_done.set()
        return res

    node.create_service(SetBool, "~/drs", answer, callback_group=ReentrantCallbackGroup())
    executor = MultiThreadedExecutor(num_threads=3, context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    client = DRSClient(domain, timeout=30.0, listen=())
    try:
        started = time.monotonic()
        answer_text = client.call_drs(True)
        took = time.monotonic() - started
    finally:
        release.set()
        first_done.wait(5.0)
        client.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        spinner.join(5.0)
    assert answer_text == "ok: request 2"
    assert RESEND_S <= took < RESEND_S + 4.0, took
    assert seen == [True, True]
