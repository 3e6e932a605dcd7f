"""Bags written with rosbags read back with the mcap libraries, our own types included."""

from collections import Counter
from pathlib import Path

import pytest
import yaml
from ament_index_python.packages import get_package_share_directory
from rosbags.typesys import Stores, get_typestore

from twbr_runner.bag_reader import BagError, bag_info, read_messages
from twbr_runner.bag_writer import BagWriter, typestore_with


def _share(package: str) -> Path:
    return Path(get_package_share_directory(package))


def test_round_trip_through_a_different_library(tmp_path):
    store = typestore_with(["twbr_msgs/msg/WheelTorques", "twbr_msgs/msg/ObstacleArray"], _share)
    wt = store.types["twbr_msgs/msg/WheelTorques"]
    header = store.types["std_msgs/msg/Header"]
    time = store.types["builtin_interfaces/msg/Time"]
    writer = BagWriter(tmp_path / "bag", store)
    writer.add_topic("/wheel_torque_cmd", "twbr_msgs/msg/WheelTorques")
    for k in range(5):
        msg = wt(header=header(stamp=time(sec=0, nanosec=5_000_000 * k), frame_id="base_link"),
                 left=0.5 * k, right=-0.25 * k)
        writer.write("/wheel_torque_cmd", 1_000 + k, store.serialize_cdr(msg, "twbr_msgs/msg/WheelTorques"))
    writer.close()

    info = bag_info(tmp_path / "bag")
    assert info["version"] == 9 and info["storage_identifier"] == "mcap" and info["message_count"] == 5
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert topics["/wheel_torque_cmd"]["topic_metadata"]["type"] == "twbr_msgs/msg/WheelTorques"
    msgs = read_messages(tmp_path / "bag")["/wheel_torque_cmd"]
    assert [t for t, _ in msgs] == [1000, 1001, 1002, 1003, 1004]
    assert [(m.left, m.right, m.header.stamp.nanosec) for _, m in msgs][3] == (1.5, -0.75, 15_000_000)


def test_an_unclosed_bag_is_reported_not_guessed(tmp_path):
    (tmp_path / "bag").mkdir()
    with pytest.raises(BagError, match=r"metadata\.yaml"):
        bag_info(tmp_path / "bag")


def test_typestore_learns_only_what_jazzy_lacks():
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    assert "twbr_msgs/msg/ControllerState" not in jazzy.types
    store = typestore_with(["twbr_msgs/msg/ControllerState", "nav_msgs/msg/Odometry"], _share)
    assert "twbr_msgs/msg/ControllerState" in store.types and "twbr_msgs/msg/Obstacle" in store.types


def test_metadata_is_what_ros2_bag_info_reads(tmp_path):
    store = typestore_with([], _share)
    clock, time = store.types["rosgraph_msgs/msg/Clock"], store.types["builtin_interfaces/msg/Time"]
    writer = BagWriter(tmp_path / "bag", store)
    writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    writer.add_topic("/unused", "rosgraph_msgs/msg/Clock")
    for k in range(3):  # receive times 2.0, 2.5 and 3.0 s
        writer.write("/clock", 2_000_000_000 + 500_000_000 * k,
                     store.serialize_cdr(clock(clock=time(sec=k, nanosec=0)), "rosgraph_msgs/msg/Clock"))
    writer.close()
    meta = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    # rosbag2's own field names and units (ros2 bag info and ros2 bag play read them: rosbag2_storage's
    # yaml_serialization.hpp), here filled with what was written
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap" and meta["message_count"] == 3
    assert meta["starting_time"]["nanoseconds_since_epoch"] == 2_000_000_000
    assert meta["duration"]["nanoseconds"] == 1_000_000_000
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert counts == {"/clock": 3, "/unused": 0}
    (relative,) = meta["relative_file_paths"]
    assert (tmp_path / "bag" / relative).stat().st_size > 0
    (entry,) = meta["files"]
    assert entry["path"] == relative and entry["message_count"] == 3


def test_a_bag_cut_short_by_a_killed_recorder_is_recovered_whole_up_to_the_cut(tmp_path):
    # Before: a recorder killed with SIGKILL left an MCAP file without its summary and no metadata.yaml, and
    # every reader refused all of it.
    from twbr_runner.recover_bag import main as recover_main

    store = typestore_with(["twbr_msgs/msg/ObstacleArray"], _share)
    array, obstacle = store.types["twbr_msgs/msg/ObstacleArray"], store.types["twbr_msgs/msg/Obstacle"]
    header, time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    point, vector = store.types["geometry_msgs/msg/Point"], store.types["geometry_msgs/msg/Vector3"]
    writer = BagWriter(tmp_path / "bag", store)
    writer.add_topic("/obstacles", "twbr_msgs/msg/ObstacleArray")
    for k in range(1500):  # about 4 kB each: several chunks
        msg = array(header=header(stamp=time(sec=k, nanosec=0), frame_id="odom"),
                    obstacles=[obstacle(id=i, position=point(x=float(k), y=float(i), z=0.0),
                                        velocity=vector(x=0.0, y=0.0, z=0.0), radius=0.5) for i in range(100)])
        writer.write("/obstacles", 10_000 + k, store.serialize_cdr(msg, "twbr_msgs/msg/ObstacleArray"))
    writer.close()
    (mcap,) = (tmp_path / "bag").glob("*.mcap")
    whole = mcap.read_bytes()
    mcap.write_bytes(whole[: int(0.7 * len(whole))])  # the power cut
    (tmp_path / "bag" / "metadata.yaml").unlink()
    with pytest.raises(BagError):
        bag_info(tmp_path / "bag")

    assert recover_main([str(tmp_path / "bag")]) == 0
    info = bag_info(tmp_path / "bag")
    msgs = read_messages(tmp_path / "bag")["/obstacles"]
    assert 0.5 * 1500 < len(msgs) == info["message_count"] < 1500  # every whole chunk before the cut
    assert [t for t, _ in msgs] == list(range(10_000, 10_000 + len(msgs)))  # in order, none invented
    last = msgs[-1][1]
    assert last.header.stamp.sec == len(msgs) - 1 and last.obstacles[99].position.y == 99.0
    assert (tmp_path / "bag" / (mcap.name + ".cut")).exists()  # the original is kept


def test_a_message_that_does_not_decode_is_left_out_and_counted_not_fatal(tmp_path):
    store = typestore_with(["twbr_msgs/msg/WheelTorques"], _share)
    wt = store.types["twbr_msgs/msg/WheelTorques"]
    writer = BagWriter(tmp_path / "bag", store)
    writer.add_topic("/wheel_torque_cmd", "twbr_msgs/msg/WheelTorques")
    header = store.types["std_msgs/msg/Header"](stamp=store.types["builtin_interfaces/msg/Time"](sec=1, nanosec=0),
                                                frame_id="base_link")
    good = bytes(store.serialize_cdr(wt(header=header, left=0.5, right=-0.5), "twbr_msgs/msg/WheelTorques"))
    writer.write("/wheel_torque_cmd", 1_000, good)
    writer.write("/wheel_torque_cmd", 1_001, good[:9])  # truncated, as a neighbour might send it
    writer.write("/wheel_torque_cmd", 1_002, good[:12] + b"\xff\xff\xff\x7f" + good[16:])  # frame_id past the end
    writer.write("/wheel_torque_cmd", 1_003, good)
    writer.close()
    skipped = Counter()
    msgs = read_messages(tmp_path / "bag", undecodable=skipped)["/wheel_torque_cmd"]
    assert [t for t, _ in msgs] == [1_000, 1_003] and msgs[1][1].left == 0.5
    assert skipped == {"/wheel_torque_cmd": 2}


def test_a_channel_without_a_ros2_decoder_is_refused_by_name(tmp_path):
    store = typestore_with(["twbr_msgs/msg/WheelTorques"], _share)
    writer = BagWriter(tmp_path / "bag", store)
    writer.add_topic("/wheel_torque_cmd", "twbr_msgs/msg/WheelTorques")
    writer.close()
    bag = tmp_path / "bag"
    mcap_path = bag / bag_info(bag)["relative_file_paths"][0]
    from mcap.writer import Writer  # a channel in another encoding, as a foreign tool might add
    with mcap_path.open("wb") as f:
        w = Writer(f)
        w.start()
        channel = w.register_channel("/raw", "json", w.register_schema("x", "jsonschema", b"{}"))
        w.add_message(channel, log_time=1, data=b"{}", publish_time=1)
        w.finish()
    with pytest.raises(BagError, match="no decoder for /raw's message encoding 'json'"):
        read_messages(bag)


def test_a_cut_anywhere_in_a_record_after_a_chunk_stops_the_salvage_with_a_reason(tmp_path):
    # Before: a recorder killed in the middle of a message index (the records after each chunk) left a file
    # the mcap reader failed on with struct.error, which recover_bag did not expect: it crashed.
    from twbr_runner.recover_bag import salvage

    writer = BagWriter(tmp_path / "bag", get_typestore(Stores.ROS2_JAZZY))
    writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    store = get_typestore(Stores.ROS2_JAZZY)
    clock, time = store.types["rosgraph_msgs/msg/Clock"], store.types["builtin_interfaces/msg/Time"]
    for k in range(20_000):  # a few chunks, each followed by its message index
        writer.write("/clock", k, store.serialize_cdr(clock(clock=time(sec=k, nanosec=0)), "rosgraph_msgs/msg/Clock"))
    writer.close()
    (mcap,) = (tmp_path / "bag").glob("*.mcap")
    whole = mcap.read_bytes()
    indexes, at = [], 8  # the records: opcode (1 byte), length (8), body; after the 8-byte magic
    while at + 9 <= len(whole) and len(indexes) < 2:
        opcode, length = whole[at], int.from_bytes(whole[at + 1:at + 9], "little")
        if opcode == 0x07:  # MessageIndex
            indexes.append((at, length))
        at += 9 + length
    assert indexes, "the bag has no message index to cut"
    for start, length in indexes:
        for cut in range(start + 1, start + min(9 + length, 40)):
            mcap.write_bytes(whole[:cut])
            taken = []
            reason = salvage(mcap, taken.append)
            assert reason.startswith("the file ends mid-record"), (cut, reason)
            assert any(type(r).__name__ == "Message" for r in taken), cut  # the chunk before it, whole
