"""drs_ros.threads: a thread the node starts is known to the operating system by its Python
name (what /proc, top -H and the benchmarks' per-thread CPU read)."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest

from drs_ros.threads import OS_NAME_BYTES, NamedThread, name_os_thread

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="thread names in /proc are Linux's"
)


def _os_name(native_id: int) -> str:
    return Path(f"/proc/self/task/{native_id}/comm").read_text().rstrip("\n")


@pytest.mark.parametrize("name", ["drs-executor", "mcap-recorder-flush", "réglage-du-volet", "x"])
def test_a_named_thread_has_its_name_in_the_operating_system(name):
    """Its name as the kernel keeps it: the first 15 bytes of its UTF-8 (a character cut in
    two is replaced), read back from /proc while the thread runs."""
    seen = {}

    def target():
        seen["os"] = _os_name(threading.get_native_id())

    thread = NamedThread(target=target, name=name)
    thread.start()
    thread.join(5.0)
    expected = name.encode()[:OS_NAME_BYTES].decode("utf-8", "replace")
    assert seen["os"] == expected
    assert not thread.is_alive()


def test_a_plain_thread_is_not_renamed_and_naming_reports_success():
    seen = {}

    def target():
        seen["before"] = _os_name(threading.get_native_id())
        seen["named"] = name_os_thread("drs-test-named")
        seen["after"] = _os_name(threading.get_native_id())

    thread = threading.Thread(target=target, name="plain-thread")
    thread.start()
    thread.join(5.0)
    assert seen["before"] != "plain-thread"
    assert seen["named"] is True and seen["after"] == "drs-test-named"
