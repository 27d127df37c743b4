"""A bag whose recorder was killed (an MCAP without its footer, no ``metadata.yaml``) is read back up to
its last whole chunk: the recorder's checkpoint closes a chunk; what came after it is lost, nothing before."""

import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from robot_controller.nodes.recorder import Recorder
from robot_controller.scoring import bag_recovery as bag_reader

TYPE = "std_msgs/msg/Float64MultiArray"
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def _cdr(value: float) -> bytes:
    layout = TYPESTORE.types["std_msgs/msg/MultiArrayLayout"]([], 0)
    return TYPESTORE.serialize_cdr(TYPESTORE.types[TYPE](layout, np.array([value])), TYPE)


def killed_bag(tmp_path, chunks: list[int], open_tail: int):
    """Messages 0, 1, … in ``chunks`` checkpointed as the recorder does, ``open_tail`` more in an open chunk,
    then the file as a SIGKILL leaves it (copied before the writer closes it); the file's size at each checkpoint."""
    writer = Writer(tmp_path / "live", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection("/controller/state", TYPE, typestore=TYPESTORE)
    k, sizes = 0, []
    for size in [*chunks, open_tail]:
        for _ in range(size):
            writer.write(connection, 1_000_000 * (k + 1), _cdr(float(k)))
            k += 1
        if size is not open_tail:
            Recorder.checkpoint(SimpleNamespace(writer=writer))
            sizes.append(writer.storage.bio.tell())
    bag = tmp_path / "bag"
    bag.mkdir()
    shutil.copy(next((tmp_path / "live").glob("*.mcap")), bag / "bag.mcap")
    writer.close()
    return bag, sizes


def values_in(bag) -> list[float]:
    with Reader(bag) as reader:
        return [TYPESTORE.deserialize_cdr(raw, TYPE).data[0] for _, _, raw in reader.messages()]


def test_a_killed_recorders_bag_is_read_back_up_to_its_last_whole_chunk(tmp_path):
    bag, _ = killed_bag(tmp_path, chunks=[30, 20], open_tail=7)
    assert bag_reader.needs_recovery(bag)
    assert bag_reader.recover(bag) == 50
    assert not bag_reader.needs_recovery(bag) and (tmp_path / "bag.torn" / "bag.mcap").is_file()
    assert values_in(bag) == [float(k) for k in range(50)]


@pytest.mark.parametrize("torn_at", [0.01, 0.3, 0.6])
def test_a_bag_torn_inside_its_last_chunk_keeps_the_chunks_before_it(tmp_path, torn_at):
    bag, (first, second) = killed_bag(tmp_path, chunks=[30, 40], open_tail=0)
    mcap = bag / "bag.mcap"
    # The kill came while the chunk of 40 was being written, ``torn_at`` of the way through.
    mcap.write_bytes(mcap.read_bytes()[: first + int(torn_at * (second - first))])
    assert bag_reader.recover(bag) == 30
    assert values_in(bag) == [float(k) for k in range(30)]


def test_a_closed_bag_needs_no_recovery(tmp_path):
    killed_bag(tmp_path, chunks=[5], open_tail=0)
    assert bag_reader.needs_recovery(tmp_path / "bag")
    assert not bag_reader.needs_recovery(tmp_path / "live")
