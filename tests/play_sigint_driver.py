"""``python play_sigint_driver.py BAG N SEED``: ``drs-bag play BAG --loop`` N times in this process
(its console entry, ``drs_ros.bag.replay.play.main``), each ended by a SIGINT at a random moment of
its
playback; one JSON line per play on stdout: ``{"rc", "after_s", "latency_s", "error"}``.

The SIGINT is real: ``os.kill`` of this process from a helper thread, which the kernel delivers
as any other; CPython then runs the handler in the main thread between two bytecodes, wherever
the player is (a sleep, a publish, the read-ahead queue, rclpy start-up or shutdown). Running the
plays in one process keeps 50 of them cheap (no interpreter and rclpy start-up each). A play that
does not return within WATCHDOG_S of its SIGINT (a deadlock) dumps every thread's stack and ends
the process with status 3.
"""

from __future__ import annotations

import faulthandler
import json
import os
import random
import signal
import sys
import threading
import time

#: Longest a play may take to return after its SIGINT before the driver calls it a hang [s].
WATCHDOG_S = 20.0
#: The SIGINT comes this long [s] after playback starts, uniformly at random.
WINDOW_S = (0.0, 0.6)


def main(bag: str, n: int, seed: int) -> int:
    from drs_ros.bag.replay.play import main as play_main
    from drs_ros.bag.replay.play.player import Player

    rng = random.Random(seed)
    playing = threading.Event()  # set by the player's thread (the main one), never by a handler
    play_once = Player._play_once

    def marked(self, loop_no):
        playing.set()
        return play_once(self, loop_no)

    Player._play_once = marked
    for _ in range(n):
        playing.clear()
        delay = rng.uniform(*WINDOW_S)
        sent = {}

        def interrupt(delay=delay, sent=sent):
            if playing.wait(60.0):
                time.sleep(delay)
                sent["t"] = time.monotonic()
                os.kill(os.getpid(), signal.SIGINT)

        killer = threading.Thread(target=interrupt, daemon=True)
        killer.start()
        error, rc = "", None
        faulthandler.dump_traceback_later(WATCHDOG_S + 60.0, exit=True)
        try:
            rc = play_main([bag, "--loop", "--rate", "2", "--read-ahead-queue-size", "20"])
        except BaseException as exc:  # noqa: BLE001 - reported, the test fails on it
            error = f"{type(exc).__name__}: {exc}"
        done = time.monotonic()
        faulthandler.cancel_dump_traceback_later()
        killer.join(timeout=WATCHDOG_S)
        latency = done - sent["t"] if "t" in sent else None
        print(
            json.dumps({"rc": rc, "after_s": delay, "latency_s": latency, "error": error}),
            flush=True,
        )
        if latency is None or latency > WATCHDOG_S:
            return 3
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3])))
