"""Reliability benchmark (issue 12, item 7): hostile input, bursts, start-of-record loss,
SIGKILL loss, orphans, and a long 64-channel recording.

Figures:
- hostile inputs tried / nodes alive: all seven nodes launched, every topic and service
  sent extreme and random values (test/rig/hostile.py), nodes alive and answering after;
- burst: 10,000 blocks (6 ch x 50 samples) published back to back, delivered to a
  subscriber / recorded by the recorder;
- start-of-record loss: ``--launches`` short launches of excitation -> rig -> acquisition
  with the recorder; seconds of /measurement/frames missing before the first recorded block;
- SIGKILL loss: a recorder at 100 blocks/s killed after 5 s; seconds between the last
  block published before the kill and the last one salvaged;
- orphans: processes left 60 s after the launcher is SIGKILLed;
- 64 ch at 2 kHz for ``--minutes`` with the recorder (bench_transport.py): blocks lost;
- replay under load: a 240-block record replayed into the twin (``residual --live``, rate
  100, paced by the twin) beside two busy loops: blocks processed / dropped, samples
  missing, max |live - offline| per channel in percentage points.

usage: python test/benchmarks/bench_reliability.py [--minutes 10] [--launches 10]
Last line: one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
TEST = HERE.parent
sys.path[:0] = [str(TEST / "rig"), str(TEST / "launch"), str(TEST / "io")]
PY = sys.executable


def hostile_figures(tmp: Path, domain: int) -> dict[str, int]:
    from test_fuzz_nodes import HostileClient, scenario_text, send_hostile

    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    p = tmp / "fuzz.yaml"
    p.write_text(scenario_text(tmp / "versions"))
    launcher = Launcher(load_scenario(p), run_dir=tmp / "fuzz_run", say=lambda s: None,
                        record=False, domain_id=domain)
    launcher.start()
    client = HostileClient(domain)
    try:
        if launcher.wait_ready(180.0):
            return {"hostile_inputs": 0, "nodes": 7, "nodes_alive": 0}
        n = send_hostile(client, np.random.default_rng(12))
        client.spin(3.0)
        answered = sum(client.call(s, r) is not None for s, r in (
            ("/identification/run", client.srv.RunIdentification.Request()),
            ("/diagnosis/run", client.srv.RunDiagnosis.Request()),
            ("/updating/run", client.srv.RunUpdating.Request())))
        alive = 7 - len(launcher.dead())
    finally:
        client.close()
        launcher.stop()
    return {"hostile_inputs": n, "nodes": 7, "nodes_alive": alive,
            "services_answering_after": answered}


def burst_figures(tmp: Path, n_blocks: int = 10_000) -> dict[str, int]:
    import rclpy
    from modal_twin_msgs.msg import SignalBlock as Msg
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.io.bag import bag_info
    from modal_twin.io.convert import block_to_msg
    from modal_twin.io.ros import qos_for
    from modal_twin.signal_block import SignalBlock

    topic = "/rig/raw"
    rec = subprocess.Popen([PY, "-m", "modal_twin.cli", "record", "-o", str(tmp / "burst"),
                            topic], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ctx = Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("burst", context=ctx)
    got: list[int] = []
    node.create_subscription(Msg, topic, lambda m: got.append(m.first_sample_index),
                             qos_for(topic))
    pub = node.create_publisher(Msg, topic, qos_for(topic))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    end = time.monotonic() + 60.0
    while pub.get_subscription_count() < 2 and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    msgs = [block_to_msg(SignalBlock(("a", "b", "c", "d", "e", "f"), 1000.0, 50 * k,
                                     np.full((6, 50), float(k))), Msg) for k in range(n_blocks)]
    for m in msgs:  # back to back: the subscriber only spins afterwards
        pub.publish(m)
    end = time.monotonic() + 120.0
    while len(got) < n_blocks and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.05)
    from rclpy.duration import Duration

    pub.wait_for_all_acked(Duration(seconds=60))
    time.sleep(2.0)
    rec.send_signal(signal.SIGINT)
    rec.wait(60)
    node.destroy_node()
    rclpy.try_shutdown(context=ctx)
    return {"burst_blocks": n_blocks, "burst_delivered": len(got),
            "burst_recorded": bag_info(tmp / "burst").message_count}


def start_loss_figures(tmp: Path, launches: int) -> dict[str, object]:
    from test_launch_reliability import chain_scenario, first_indices

    from modal_twin.launch import launch

    scen = chain_scenario(tmp)
    lost_s: list[float] = []
    for k in range(launches):
        res = launch(scen, run_dir=tmp / f"launch{k}", say=lambda s: None)
        first = first_indices(res.bag) if res.bag is not None and res.exit_code == 0 else {}
        f0 = first.get("/measurement/frames")
        lost_s.append(1.0 if f0 is None else f0 / 1000.0)  # the whole 1 s drive if nothing
    return {"launches": launches, "launches_with_first_sample": sum(x == 0 for x in lost_s),
            "start_loss_max_s": max(lost_s)}


def sigkill_figures(tmp: Path) -> dict[str, float]:
    from modal_twin.io.bag import read_blocks, salvage

    bag = tmp / "killed"
    rec = subprocess.Popen([PY, "-m", "modal_twin.cli", "record", "-o", str(bag), "/rig/raw"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    pub = subprocess.Popen([PY, str(TEST / "io" / "pub_blocks.py"), "/rig/raw", "1000", "10",
                            "4", "100"], stdout=subprocess.PIPE, text=True)
    assert pub.stdout is not None
    last, t_start = -1, None
    for line in pub.stdout:
        if line.startswith("published"):
            last = int(line.split()[1])
            t_start = t_start or time.monotonic()
            if time.monotonic() - t_start >= 5.0:
                rec.send_signal(signal.SIGKILL)
                break
    rec.wait()
    pub.kill()
    pub.wait()
    blocks = read_blocks(salvage(bag).path, "/rig/raw")
    kept = blocks[-1].first_index // 10 if blocks else -1
    return {"sigkill_loss_s": round((last - kept) / 100.0, 3)}


def orphan_figures(tmp: Path) -> dict[str, int]:
    from test_launch_reliability import chain_scenario, kill_launcher_and_count_orphans

    n, left = kill_launcher_and_count_orphans(
        chain_scenario(tmp, duration=0, drive_s=60), tmp / "orphan_run")
    return {"processes_under_launcher": n, "orphans_after_launcher_sigkill": left}


def long_run_figures(minutes: float) -> dict[str, object]:
    r = subprocess.run([PY, str(HERE / "bench_transport.py"), "--duration", str(60 * minutes)],
                       capture_output=True, text=True, check=False)
    last = (r.stdout.strip().splitlines() or ["{}"])[-1]
    fig = json.loads(last) if last.startswith("{") else {}
    return {"long_minutes": minutes, "long_blocks_sent": fig.get("blocks_sent"),
            "long_blocks_lost_subscriber": fig.get("blocks_lost"),
            "long_blocks_lost_recorder": fig.get("blocks_lost_recorder")}


def replay_load_figures(tmp: Path, busy: int = 2) -> dict[str, object]:
    """A record replayed into the twin (``residual --live``) beside ``busy`` CPU-burning loops.

    The S1 truth's 12 s record in 240 blocks at rate 100 (the replay paced by the twin's
    answers); blocks processed and dropped, samples missing, and max |live - offline| over
    every channel's NRMSE and Eq. (8), in percentage points.
    """
    import contextlib
    import io
    import re

    sys.path.insert(0, str(TEST / "diagnosis"))
    from test_imported_records import BUILDING, _own_npz, reblocked

    from modal_twin.cli import main as cli

    roles = tmp / "map.yaml"
    roles.write_text(
        "channels:\n"
        "  - {name: ground_x, role: input, quantity: acceleration, direction: x}\n"
        "  - {name: ground_y, role: input, quantity: acceleration, direction: y}\n"
        "  - {name: roof_corner_x, role: output, quantity: acceleration, location: R_P1,"
        " direction: x}\n")
    say = io.StringIO()
    with contextlib.redirect_stdout(say), contextlib.redirect_stderr(say):
        cli(["import", str(_own_npz(tmp / "quake.npz", "quake", 2, 3.5)), "--map", str(roles),
             "--out", str(tmp / "quake_1s")])
        bag = reblocked(tmp / "quake_1s", tmp / "quake", 0.05)
        cli(["residual", str(BUILDING), str(bag), "--json", str(tmp / "offline.json")])
        loops = [subprocess.Popen([PY, "-c", "while True: pass"]) for _ in range(busy)]
        try:
            code = cli(["residual", str(BUILDING), str(bag), "--live", "--rate", "100",
                        "--run-dir", str(tmp / "replay_load"), "--json",
                        str(tmp / "live.json")])
        finally:
            for proc in loops:
                proc.kill()
                proc.wait()
    off = json.loads((tmp / "offline.json").read_text())
    live = json.loads((tmp / "live.json").read_text()) if code == 0 else {}
    diff = [100 * abs(live[c][k] - off[c][k]) for c in off if c in live for k in ("nrmse", "eq8")]
    logs = tmp / "replay_load" / "logs"
    answered = re.search(r"(\d+) of (\d+) blocks answered", (logs / "replay.log").read_text())
    twin = re.search(r": (\d+) compared, (\d+) missing; blocks dropped (\d+)",
                     (logs / "twin.log").read_text())
    return {"replay_load_busy_loops": busy, "replay_load_exit_code": code,
            "replay_load_channels": len(off), "replay_load_channels_live": len(live),
            "replay_load_blocks": int(answered[2]) if answered else None,
            "replay_load_blocks_processed": int(answered[1]) if answered else None,
            "replay_load_blocks_dropped": int(twin[3]) if twin else None,
            "replay_load_samples_compared": int(twin[1]) if twin else None,
            "replay_load_samples_missing": int(twin[2]) if twin else None,
            "replay_load_max_abs_live_minus_offline_pp": max(diff) if diff else None}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=10.0, help="64 ch at 2 kHz run length")
    ap.add_argument("--launches", type=int, default=10)
    a = ap.parse_args()
    domain = int(os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(150, 200) % 101 + 1)))
    tmp = Path(tempfile.mkdtemp(prefix="bench_reliability_"))
    fig: dict[str, object] = {}
    for name, step in (("hostile", lambda: hostile_figures(tmp, domain)),
                       ("burst", lambda: burst_figures(tmp)),
                       ("start", lambda: start_loss_figures(tmp, a.launches)),
                       ("sigkill", lambda: sigkill_figures(tmp)),
                       ("orphans", lambda: orphan_figures(tmp)),
                       ("long", lambda: long_run_figures(a.minutes)),
                       ("replay_load", lambda: replay_load_figures(tmp))):
        t0 = time.monotonic()
        part = step()
        fig.update(part)
        print(f"{name}: {part} ({time.monotonic() - t0:.0f} s)", flush=True)
    print(json.dumps(fig))
    return 0


if __name__ == "__main__":
    sys.exit(main())
