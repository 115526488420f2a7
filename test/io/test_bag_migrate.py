"""A bag recorded before ChannelInfo had ``role`` and ``node`` still reads and replays."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from modal_twin.io.bag import read_messages, read_raw
from modal_twin.io.convert import channel_map_from_msg
from modal_twin.io.typestore import typestore

MAP = "modal_twin_msgs/msg/ChannelMap"
OLD_INFO = """string name
string quantity
string unit
string location
string direction
float64 sensitivity
float64[3] position_m
"""
OLD_MAP = """std_msgs/Header header
string source
modal_twin_msgs/ChannelInfo[] channels
"""


def old_bag(path: Path) -> None:
    """A bag written with the definitions of the first wave (no role, no node)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(OLD_INFO, "modal_twin_msgs/msg/ChannelInfo"))
    store.register(get_types_from_msg(OLD_MAP, MAP))
    T = store.types
    info = [T["modal_twin_msgs/msg/ChannelInfo"](
        name=n, quantity="acceleration", unit="m/s^2", location=loc, direction="x",
        sensitivity=0.102, position_m=np.array([1.0, 2.0, 3.0])) for n, loc in
        (("table_ax", "table"), ("F1_C1_x", "F1_C1"))]
    head = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=5, nanosec=7),
                                    frame_id="rig")
    msg = T[MAP](header=head, source="rig", channels=info)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/measurement/channels", MAP, typestore=store)
        w.write(conn, 10, store.serialize_cdr(msg, MAP))


def test_old_channel_maps_read_with_empty_new_fields(tmp_path: Path) -> None:
    old_bag(tmp_path / "bag")
    [(topic, t_ns, msg)] = list(read_messages(tmp_path / "bag"))
    assert (topic, t_ns, msg.source) == ("/measurement/channels", 10, "rig")
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (5, 7)
    chans = channel_map_from_msg(msg)
    assert [c.name for c in chans] == ["table_ax", "F1_C1_x"]
    assert [c.role for c in chans] == ["", ""]  # new field, empty: the role from the name
    assert [c.effective_role for c in chans] == ["input", "output"]
    assert chans[1].location == "F1_C1" and chans[1].position_m == (1.0, 2.0, 3.0)
    assert chans[0].sensitivity == 0.102
    # replay publishes these bytes: they decode with the project's definition
    [(_, mt, _, raw)] = list(read_raw(tmp_path / "bag"))
    again = typestore().deserialize_cdr(raw, mt)
    assert again.channels[1].name == "F1_C1_x" and again.channels[1].node == ""


def test_current_bags_pass_untouched(tmp_path: Path) -> None:
    store = typestore()
    T = store.types
    info = T["modal_twin_msgs/msg/ChannelInfo"](
        name="a", quantity="force", unit="N", location="", direction="x", sensitivity=1.0,
        position_m=np.zeros(3), role="input", node="N12")
    head = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                    frame_id="")
    raw = store.serialize_cdr(T[MAP](header=head, source="s", channels=[info]), MAP)
    with Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/measurement/channels", MAP, typestore=store)
        w.write(conn, 1, raw)
    [(_, _, _, back)] = list(read_raw(tmp_path / "bag"))
    assert back == bytes(raw)
    assert channel_map_from_msg(store.deserialize_cdr(back, MAP))[0].role == "input"


def test_roles_and_nodes_travel_in_the_ros_message() -> None:
    from modal_twin_msgs.msg import ChannelInfo, ChannelMap

    from modal_twin.channels import ChannelSpec
    from modal_twin.io.convert import channel_map_to_msg

    chans = [ChannelSpec("base_NS", "acceleration", "base", "x", role="input", node="N1"),
             ChannelSpec("strain_3", "strain", "girder", "x", 2.0, (1.0, 0.0, 0.5),
                         role="reference", node="N40"),
             ChannelSpec("p", "pressure", "deck", "z", role="output", unit_si="kPa")]
    back = channel_map_from_msg(channel_map_to_msg(chans, "file", ChannelMap, ChannelInfo))
    assert back == chans
    assert back[2].unit == "kPa" and back[0].unit == "m/s^2"
