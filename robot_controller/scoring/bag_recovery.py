"""A bag the recorder did not close (it was killed): its complete chunks read back into a bag that opens, the torn
file kept beside it."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

MAGIC = b"\x89MCAP0\r\n"
OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_FOOTER = 0x03, 0x04, 0x05, 0x06, 0x02


@dataclass
class Scan:
    schemas: dict[int, str] = field(default_factory=dict)  #: schema id → message type name
    channels: dict[int, tuple[str, int]] = field(default_factory=dict)  #: channel id → (topic, schema id)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)  #: (channel id, log time ns, CDR)


def needs_recovery(bag_dir: Path) -> bool:
    """No ``metadata.yaml`` or an MCAP without its end: the recorder did not close it."""
    files = sorted(bag_dir.glob("*.mcap"))
    if not files:
        return False
    if not (bag_dir / "metadata.yaml").is_file():
        return True
    with files[0].open("rb") as f:
        f.seek(0, 2)
        if f.tell() < 2 * len(MAGIC):
            return True
        f.seek(-len(MAGIC), 2)
        return f.read() != MAGIC


def scan(data: bytes) -> Scan:
    """The schemas, channels and messages of an MCAP file's bytes, up to where it tears."""
    out = Scan()
    if not data.startswith(MAGIC):
        raise ValueError("not an MCAP file (bad magic)")
    _records(memoryview(data)[len(MAGIC) :], out)
    return out


def _records(view: memoryview, out: Scan) -> None:
    offset = 0
    while offset + 9 <= len(view):
        opcode = view[offset]
        (length,) = struct.unpack_from("<Q", view, offset + 1)
        start, end = offset + 9, offset + 9 + length
        if end > len(view):
            return  # torn here
        content = view[start:end]
        if opcode == OP_SCHEMA:
            (schema_id,) = struct.unpack_from("<H", content)
            out.schemas[schema_id] = _string(content, 2)[0]
        elif opcode == OP_CHANNEL:
            (channel_id, schema_id), topic = struct.unpack_from("<HH", content), _string(content, 4)[0]
            out.channels[channel_id] = (topic, schema_id)
        elif opcode == OP_MESSAGE:
            channel_id, _, log_time, _ = struct.unpack_from("<HIQQ", content)
            out.messages.append((channel_id, log_time, bytes(content[22:])))
        elif opcode == OP_CHUNK:
            compression, position = _string(content, 28)
            (records_length,) = struct.unpack_from("<Q", content, position)
            if compression:
                raise ValueError(f"compressed chunks ({compression}) are not recovered")
            _records(content[position + 8 : position + 8 + records_length], out)
        elif opcode == OP_FOOTER:
            return
        offset = end


def _string(view: memoryview, offset: int) -> tuple[str, int]:
    (length,) = struct.unpack_from("<I", view, offset)
    return bytes(view[offset + 4 : offset + 4 + length]).decode(), offset + 4 + length


def recover(bag_dir: Path) -> int:
    """Rewrite ``bag_dir`` as a complete bag from what its torn MCAP holds; returns how many messages were recovered."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    files = sorted(bag_dir.glob("*.mcap"))
    if not files:
        raise FileNotFoundError(f"{bag_dir}: no .mcap file")
    found = scan(files[0].read_bytes())
    torn = bag_dir.with_name(bag_dir.name + ".torn")
    if torn.exists():
        raise FileExistsError(f"{torn} exists: an earlier recovery was interrupted; remove it to try again")
    bag_dir.rename(torn)
    typestore = get_typestore(Stores.ROS2_JAZZY)
    writer = Writer(bag_dir, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connections = {}
    for channel_id, (topic, schema_id) in sorted(found.channels.items()):
        type_name = found.schemas.get(schema_id)
        if type_name is not None:
            connections[channel_id] = writer.add_connection(topic, type_name, typestore=typestore)
    written = 0
    for channel_id, log_time, data in sorted(found.messages, key=lambda m: m[1]):
        if channel_id in connections:
            writer.write(connections[channel_id], log_time, data)
            written += 1
    writer.close()
    return written
