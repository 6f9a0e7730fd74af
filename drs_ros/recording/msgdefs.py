"""Full ``ros2msg`` message definitions and RIHS01 type hashes, as rosbag2 (Jazzy) stores them.

rosbag2's ``LocalMessageDefinitionSource`` builds the schema text of an MCAP channel like this:

* the root type's ``.msg`` file, verbatim;
* its dependencies: every line-leading field type of the text that is not a primitive
  (``(?:^|\\n)\\s*([a-zA-Z0-9_/]+)(?:\\[[^\\]]*\\])?\\s+``), qualified with the root's package when
  it has no ``/``, visited in sorted order, depth-first, each at most once. Each is appended as
  ``"\\n"``, a line of 80 ``=``, a line ``MSG: pkg/Type`` (the name as written in the field, e.g.
  ``std_msgs/Header``) and that type's ``.msg`` text with its own dependencies after it.

The ``.msg`` files and the ``.json`` type descriptions (holding the ``RIHS01_...`` hashes) are
looked up under ``<prefix>/share/<pkg>/msg/`` for every prefix of ``AMENT_PREFIX_PATH`` and then
``sys.prefix`` (the PyPI wheels install them into the venv), which is where
``ament_index_python.get_package_share_directory`` would find them.

Service introspection events (``pkg/srv/Name_Event`` on ``<service>/_service_event``): rosbag2
Jazzy stores the ``.srv`` text behind an ``SRV:`` delimiter, which no message parser reads
(rosbags, mcap_ros2 and Foxglove reject it: ros2/rosbag2#2365). We store what that report
settles on: the event type's own message definition, ``service_msgs/ServiceEventInfo info``,
``Name_Request[<=1] request``, ``Name_Response[<=1] response``, followed by the definitions of
``ServiceEventInfo`` (and its dependencies), the request and the response (the two halves of the
``.srv`` text).

Only ``functools.lru_cache`` holds state: one entry per type.
"""

from __future__ import annotations

import functools
import importlib
import json
import os
import re
import sys
from pathlib import Path

from ..errors import DRSRosError

#: rosbag2's delimiter line between definitions (80 ``=``).
DELIMITER = "=" * 80
#: Field types rosbag2 does not follow as dependencies.
PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
    }
)
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_NAME = r"[a-zA-Z][a-zA-Z0-9_]*"
_TYPE_NAME = re.compile(rf"^({_NAME})/(?:({_NAME})/)?({_NAME})$")
#: Suffix of a service introspection event type (``std_srvs/srv/SetBool_Event``).
SERVICE_EVENT_SUFFIX = "_Event"
#: Recursion bound (rosbag2 uses 50).
MAX_DEPTH = 50


class MessageDefinitionError(DRSRosError, LookupError):
    """A message type is malformed or its ``.msg`` / ``.json`` description cannot be found."""


def type_name(msg_type) -> str:
    """Canonical ``pkg/msg/Type`` of a message class or a name (``pkg/Type``, ``pkg/msg/Type``).

    Parameters
    ----------
    msg_type : type or str
        A generated rclpy message class (e.g. ``sensor_msgs.msg.JointState``) or its name.

    Returns
    -------
    str
        e.g. ``"sensor_msgs/msg/JointState"``.
    """
    if isinstance(msg_type, str):
        pkg, ns, name = _split(msg_type)
        return f"{pkg}/{ns}/{name}"
    module = getattr(msg_type, "__module__", "") or ""
    parts = module.split(".")
    if (
        len(parts) < 2
        or parts[1] not in ("msg", "srv")
        or not hasattr(msg_type, "_fields_and_field_types")
    ):
        raise MessageDefinitionError(
            f"expected a ROS message class (e.g. sensor_msgs.msg.JointState or "
            f"std_srvs.srv.SetBool.Event) or a name 'pkg/msg/Type', got {msg_type!r}"
        )
    return f"{parts[0]}/{parts[1]}/{msg_type.__name__}"


def is_service_event(name: str) -> bool:
    """Whether ``name`` (``pkg/ns/Type``) is a service introspection event type."""
    _pkg, ns, typ = _split(name)
    return ns == "srv" and typ.endswith(SERVICE_EVENT_SUFFIX)


def _split(name: str) -> tuple[str, str, str]:
    match = _TYPE_NAME.match(name)
    if match is None:
        raise MessageDefinitionError(
            f"invalid message type name {name!r}: expected 'pkg/Type' or 'pkg/msg/Type'"
        )
    pkg, ns, typ = match.groups()
    return pkg, ns or "msg", typ


def message_class(msg_type) -> type:
    """The rclpy message class of a name or class (imports ``pkg.msg``)."""
    if not isinstance(msg_type, str):
        type_name(msg_type)  # validates
        return msg_type
    pkg, ns, name = _split(msg_type)
    try:
        module = importlib.import_module(f"{pkg}.{ns}")
        return getattr(module, name)
    except (ImportError, AttributeError) as exc:
        raise MessageDefinitionError(
            f"cannot import message class {pkg}.{ns}.{name} for {msg_type!r}: {exc}"
        ) from exc


def search_prefixes() -> tuple[Path, ...]:
    """Install prefixes searched for ``share/<pkg>``: ``AMENT_PREFIX_PATH`` then ``sys.prefix``."""
    out: list[Path] = []
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry and Path(entry) not in out:
            out.append(Path(entry))
    if Path(sys.prefix) not in out:
        out.append(Path(sys.prefix))
    return tuple(out)


def interface_file(name: str, extension: str) -> Path:
    """Path of ``share/<pkg>/<ns>/<Type><extension>`` for a type name (``.msg``, ``.json``...)."""
    pkg, ns, typ = _split(name)
    prefixes = search_prefixes()
    for prefix in prefixes:
        path = prefix / "share" / pkg / ns / f"{typ}{extension}"
        if path.is_file():
            return path
    raise MessageDefinitionError(
        f"no {extension} file for {name!r} under share/{pkg}/{ns}/ of "
        f"{[str(p) for p in prefixes]} (is the ros-jazzy-{pkg.replace('_', '-')} wheel installed?)"
    )


@functools.lru_cache(maxsize=256)
def _msg_text(name: str) -> str:
    return interface_file(name, ".msg").read_text(encoding="utf-8")


def dependencies(text: str, package: str) -> list[str]:
    """Non-primitive field types of a ``.msg`` text, sorted, qualified as rosbag2 does.

    Parameters
    ----------
    text : str
        The ``.msg`` text.
    package : str
        Package of the type the text belongs to (qualifies unqualified names).
    """
    deps = set()
    for match in _FIELD_TYPE.finditer(text):
        typ = match.group(1)
        if typ in PRIMITIVE_TYPES:
            continue
        deps.add(typ if "/" in typ else f"{package}/{typ}")
    return sorted(deps)


@functools.lru_cache(maxsize=256)
def _full_text(name: str) -> str:
    seen: set[str] = set()

    def append(dep_name: str, depth: int) -> str:
        if depth <= 0:
            raise MessageDefinitionError(
                f"reached the maximum recursion depth {MAX_DEPTH} resolving {name!r}"
            )
        text = _msg_text(type_name(dep_name))
        result = text
        for dep in dependencies(text, _split(dep_name)[0]):
            if dep not in seen:
                seen.add(dep)
                result += f"\n{DELIMITER}\nMSG: {dep}\n" + append(dep, depth - 1)
        return result

    return append(name, MAX_DEPTH)


@functools.lru_cache(maxsize=64)
def _service_event_text(name: str) -> str:
    pkg, _ns, typ = _split(name)
    service = typ[: -len(SERVICE_EVENT_SUFFIX)]
    request, sep, response = (
        interface_file(f"{pkg}/srv/{service}", ".srv")
        .read_text(encoding="utf-8")
        .partition("---\n")
    )
    if not sep:
        raise MessageDefinitionError(f"{pkg}/srv/{service}.srv has no '---' line")
    info = "service_msgs/msg/ServiceEventInfo"
    parts = [
        f"service_msgs/ServiceEventInfo info\n{pkg}/srv/{service}_Request[<=1] request\n"
        f"{pkg}/srv/{service}_Response[<=1] response\n",
        f"{DELIMITER}\nMSG: service_msgs/ServiceEventInfo\n{_full_text(info)}",
        f"{DELIMITER}\nMSG: {pkg}/srv/{service}_Request\n{request}",
        f"{DELIMITER}\nMSG: {pkg}/srv/{service}_Response\n{response}",
    ]
    return "\n".join(p.rstrip("\n") for p in parts) + "\n"


def full_definition(msg_type) -> str:
    """The complete ``ros2msg`` definition rosbag2 stores as the MCAP schema data.

    Parameters
    ----------
    msg_type : type or str
        Message class or name.

    Returns
    -------
    str
        Root ``.msg`` text followed by every dependency (delimiter line, ``MSG: pkg/Type``, text);
        for a service event, its message form (see the module docstring).
    """
    name = type_name(msg_type)
    return _service_event_text(name) if is_service_event(name) else _full_text(name)


@functools.lru_cache(maxsize=256)
def _hash(name: str) -> str:
    path = interface_file(name, ".json")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        for entry in data["type_hashes"]:
            if entry["type_name"] == name:
                return str(entry["hash_string"])
    except (ValueError, KeyError, TypeError) as exc:
        raise MessageDefinitionError(f"malformed type description {str(path)!r}: {exc}") from exc
    raise MessageDefinitionError(f"type description {str(path)!r} holds no hash for {name!r}")


def type_hash(msg_type) -> str:
    """The ``RIHS01_<sha256 hex>`` type description hash of a message type (from its ``.json``).
    Service events are not asked: their channels carry no hash (see
    :mod:`drs_ros.recording.mcap_recorder`)."""
    return _hash(type_name(msg_type))


__all__ = [
    "DELIMITER",
    "MessageDefinitionError",
    "dependencies",
    "full_definition",
    "interface_file",
    "is_service_event",
    "message_class",
    "search_prefixes",
    "type_hash",
    "type_name",
]
