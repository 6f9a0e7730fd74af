"""A bag on disk: which files it has, in which order, and its ``metadata.yaml``, checked.

:func:`resolve` is the one place the bag tools find a bag's files: those a bag directory's
``metadata.yaml`` lists (:func:`read_metadata` checks it as far as the tools read it), or, without
one (a recording killed before it finished), its ``.mcap`` (else ``.db3``) files in rosbag2's
split order; a file is a bag of one file. The storage is MCAP or sqlite3 (``.db3``). The errors
of reading a bag are defined here, with the first place that raises them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from drs_ros.errors import DRSRosError


class BagReadError(DRSRosError):
    """The bag cannot be read or is not what it claims: missing, not MCAP, truncated, corrupt,
    inconsistent with its summary or ``metadata.yaml``, or holding inexact message bytes."""


class BagMetadataError(BagReadError):
    """A bag directory's ``metadata.yaml`` is unreadable, not YAML, or not a rosbag2 bag's
    metadata (a missing key, or a value of the wrong type or range). The message names the file
    and the field."""


@dataclass(frozen=True)
class BagFiles:
    """A bag's files, as :func:`resolve` found them.

    Attributes
    ----------
    files : tuple of Path
        The ``.mcap`` files, in recording order (one for a file or an unsplit bag).
    bag_dir : Path or None
        The bag directory (None for a bare file).
    metadata : dict or None
        The checked ``rosbag2_bagfile_information`` of ``metadata.yaml`` (:func:`read_metadata`),
        None when there is none.
    storage : {"mcap", "sqlite3"}
        rosbag2's storage of the files: MCAP, or sqlite3 (``.db3``, read through rosbags).
    """

    files: tuple[Path, ...]
    bag_dir: Path | None
    metadata: dict[str, Any] | None
    storage: str = "mcap"


#: rosbag2's storages the tools read.
STORAGES = ("mcap", "sqlite3")

_SPLIT_INDEX = re.compile(r"(.*?)(\d+)")


def _file_order(path: Path) -> tuple[str, int, str]:
    """rosbag2's split order: ``name_2.mcap`` before ``name_10.mcap`` (numerically)."""
    found = _SPLIT_INDEX.fullmatch(path.stem)
    return (found[1], int(found[2]), path.name) if found else (path.stem, -1, path.name)


def resolve(path: str | Path, require_metadata: bool = True) -> BagFiles:
    """The files of a bag directory or a file, in order: the one resolver of the bag tools.

    A bag directory's files are those its ``metadata.yaml`` lists (``relative_file_paths``, in
    that order; every one must exist). Without ``metadata.yaml`` (a recording killed before it
    finished) the directory is refused unless ``require_metadata`` is False; then its ``*.mcap``
    files are taken in rosbag2's split order (``name_0``, ``name_1``, ..., ``name_10``). A file is
    a bag of one file.

    Raises
    ------
    BagReadError
        No such path; a directory without ``metadata.yaml`` (with ``require_metadata``) or without
        any ``.mcap`` file; a listed file that does not exist.
    BagMetadataError
        ``metadata.yaml`` is malformed (:func:`read_metadata`).
    """
    path = Path(path)
    if path.is_dir():
        meta_path = path / "metadata.yaml"
        if not meta_path.is_file():
            files = tuple(sorted(path.glob("*.mcap"), key=_file_order))
            storage = "mcap"
            if not files:
                files = tuple(sorted(path.glob("*.db3"), key=_file_order))
                storage = "sqlite3"
            if require_metadata:
                hint = (
                    f"; {', '.join(f.name for f in files)} may be an unfinished recording: "
                    f"drs-bag recover {path} -o OUT"
                    if files
                    else ""
                )
                raise BagReadError(f"{str(path)!r}: no metadata.yaml in the bag directory{hint}")
            if not files:
                raise BagReadError(f"{str(path)!r}: bag directory holds no .mcap or .db3 file")
            return BagFiles(files, path, None, storage)
        meta = read_metadata(meta_path)
        files = tuple(path / name for name in meta["relative_file_paths"])
        missing = [f.name for f in files if not f.is_file()]
        if missing:
            raise BagReadError(
                f"{str(meta_path)!r}: lists {', '.join(missing)}, which the bag directory does "
                "not hold"
            )
        return BagFiles(files, path, meta, meta.get("storage_identifier", "mcap"))
    if not path.is_file():
        raise BagReadError(f"{str(path)!r}: no such bag file or directory")
    return BagFiles((path,), None, None, "sqlite3" if path.suffix == ".db3" else "mcap")


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def read_metadata(meta_path: str | Path) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` of a ``metadata.yaml``, checked as far as the bag tools
    read it.

    Required: a mapping ``rosbag2_bagfile_information`` holding ``relative_file_paths`` (a
    non-empty list of file names inside the bag directory), ``message_count`` (an integer >= 0),
    ``topics_with_message_count`` (a list of ``{topic_metadata: {name, type: str,
    serialization_format: str (optional)}, message_count: int >= 0}``),
    ``starting_time.nanoseconds_since_epoch`` and ``duration.nanoseconds`` (integers >= 0 [ns]).
    Optional: ``storage_identifier`` (``mcap`` or ``sqlite3``; an uncompressed sqlite3 bag),
    ``ros_distro`` (a string).

    Raises
    ------
    BagMetadataError
        Naming the file and the first field that is missing or wrong, with its value.
    """
    fields = _Fields(str(meta_path))
    data = _load_yaml(meta_path, fields)
    if not isinstance(data, dict):
        raise fields.bad(f"the document is {type(data).__name__}, not a mapping")
    key = "rosbag2_bagfile_information"
    if key not in data:
        raise fields.bad(f"no key {key!r} (keys: {_shown(sorted(map(str, data)))})")
    meta = fields.mapping(data[key], key)
    _check_files(fields, meta, key)
    fields.count(fields.get(meta, key, "message_count"), f"{key}.message_count")
    _check_topics(fields, meta, key)
    for field_name, unit in (
        ("starting_time", "nanoseconds_since_epoch"),
        ("duration", "nanoseconds"),
    ):
        value = fields.mapping(fields.get(meta, key, field_name), f"{key}.{field_name}")
        fields.count(fields.get(value, f"{key}.{field_name}", unit), f"{key}.{field_name}.{unit}")
    storage = meta.get("storage_identifier", "mcap")
    if storage not in STORAGES:
        raise fields.bad(
            f"{key}.storage_identifier is {_shown(storage)}: only {STORAGES} bags are read"
        )
    if storage == "sqlite3" and meta.get("compression_format"):
        raise fields.bad(
            f"{key}.compression_format is {_shown(meta['compression_format'])}: "
            "compressed sqlite3 bags are not read (decompress with ros2 bag "
            "convert)"
        )
    distro = meta.get("ros_distro")
    if distro is not None and not isinstance(distro, str):
        raise fields.bad(f"{key}.ros_distro must be a string, got {_shown(distro)}")
    return meta


class _Fields:
    """The checks of a metadata file's fields, each raising a :class:`BagMetadataError` that
    names the file (``where``), the field and its value."""

    def __init__(self, where: str):
        self.where = where

    def bad(self, text: str) -> BagMetadataError:
        return BagMetadataError(f"{self.where!r}: not a rosbag2 metadata file: {text}")

    def mapping(self, value: Any, name: str) -> dict:
        if not isinstance(value, dict):
            raise self.bad(f"{name} must be a mapping, got {_shown(value)}")
        return value

    def get(self, parent: dict, name: str, field_name: str) -> Any:
        if field_name not in parent:
            raise self.bad(f"{name}.{field_name} is missing")
        return parent[field_name]

    def count(self, value: Any, name: str) -> None:
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self.bad(f"{name} must be an integer >= 0, got {_shown(value)}")

    def text(self, value: Any, name: str) -> None:
        if not isinstance(value, str) or not value:
            raise self.bad(f"{name} must be a non-empty string, got {_shown(value)}")


def _load_yaml(meta_path: str | Path, fields: _Fields) -> Any:
    """The YAML document of ``meta_path``; a file that cannot be read or is not YAML raises."""
    where = fields.where
    try:
        # libyaml's safe loader when PyYAML has it (13x faster: a catalogue reads thousands)
        return yaml.load(
            Path(meta_path).read_text(encoding="utf-8"),
            Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader),
        )
    except (OSError, UnicodeDecodeError) as exc:
        raise BagMetadataError(f"{where!r}: cannot be read ({exc})") from exc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise fields.bad(f"not YAML ({problem}{at})") from exc


def _check_files(fields: _Fields, meta: dict, key: str) -> None:
    """``relative_file_paths``: a non-empty list of names of files inside the bag directory."""
    files = fields.get(meta, key, "relative_file_paths")
    if not isinstance(files, list) or not files:
        raise fields.bad(f"{key}.relative_file_paths must be a non-empty list, got {_shown(files)}")
    for i, name in enumerate(files):
        fields.text(name, f"{key}.relative_file_paths[{i}]")
        if Path(name).is_absolute() or ".." in Path(name).parts:
            raise fields.bad(
                f"{key}.relative_file_paths[{i}] must name a file inside the bag directory, "
                f"got {_shown(name)}"
            )


def _check_topics(fields: _Fields, meta: dict, key: str) -> None:
    """``topics_with_message_count``: a list of topics, each named and typed, with its count."""
    topics = fields.get(meta, key, "topics_with_message_count")
    if not isinstance(topics, list):
        raise fields.bad(f"{key}.topics_with_message_count must be a list, got {_shown(topics)}")
    for i, entry in enumerate(topics):
        name = f"{key}.topics_with_message_count[{i}]"
        fields.mapping(entry, name)
        topic = fields.mapping(fields.get(entry, name, "topic_metadata"), f"{name}.topic_metadata")
        for part in ("name", "type"):
            fields.text(
                fields.get(topic, f"{name}.topic_metadata", part), f"{name}.topic_metadata.{part}"
            )
        if "serialization_format" in topic:
            fields.text(
                topic["serialization_format"], f"{name}.topic_metadata.serialization_format"
            )
        fields.count(fields.get(entry, name, "message_count"), f"{name}.message_count")


__all__ = ["STORAGES", "BagFiles", "BagMetadataError", "BagReadError", "read_metadata", "resolve"]
