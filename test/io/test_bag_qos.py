"""Offered QoS written with every topic of a bag: latched topics stay latched on replay."""

from __future__ import annotations

from pathlib import Path

from rosbags.interfaces import QosDurability, QosHistory, QosReliability
from rosbags.rosbag2 import Reader

from modal_twin.io.bag import BagWriter
from modal_twin.io.topics import BURST_LIMIT_BLOCKS


def test_metadata_holds_the_offered_qos_of_each_topic(tmp_path: Path) -> None:
    topics = {"/measurement/frames": "modal_twin_msgs/msg/SignalBlock",
              "/model/parameters": "modal_twin_msgs/msg/ModelParameters",
              "/diagnosis/report": "modal_twin_msgs/msg/DiagnosisReport",
              "/updating/report": "modal_twin_msgs/msg/UpdateReport"}
    with BagWriter(tmp_path / "bag", topics):
        pass
    text = (tmp_path / "bag" / "metadata.yaml").read_text()
    assert "offered_qos_profiles" in text
    with Reader(tmp_path / "bag") as r:
        qos = {c.topic: c.ext.offered_qos_profiles[0] for c in r.connections}
    for latched in ("/model/parameters", "/diagnosis/report"):
        q = qos[latched]
        assert q.durability is QosDurability.TRANSIENT_LOCAL and q.depth == 1
        assert q.reliability is QosReliability.RELIABLE
    frames = qos["/measurement/frames"]
    assert frames.durability is QosDurability.VOLATILE
    assert (frames.history, frames.depth) == (QosHistory.KEEP_LAST, BURST_LIMIT_BLOCKS)
    assert qos["/updating/report"].depth == 50
