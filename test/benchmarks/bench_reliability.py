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
- bombs (issue 21): a compressed bomb per reader (NPZ record / matrix model / excitation
  record, .mat cell and dense, strong-motion zip, CSV, UFF): refused, peak RSS (MB);
- damaged records (issue 21): a 64-byte flip in the middle chunk salvaged (kept, reported
  lost, silent loss), residual on a record with one malformed frame, report's metrics
  with one malformed message.
- paths (issue 21): symbolic links to files outside, FIFOs where a file is expected,
  names that would move the run folder, outputs that exist already, each through the
  command line or the twin's model loading in a sandbox: cases, hangs (no answer in 60 s),
  links followed, bytes written outside the sandbox's run folder, files overwritten,
  tracebacks and multi-line errors.
- replay under load: a 240-block record replayed into the twin (``residual --live``, rate
  100, paced by the twin) beside two busy loops: blocks processed / dropped, samples
  missing, max |live - offline| per channel in percentage points.

usage: python test/benchmarks/bench_reliability.py [--minutes 10] [--launches 10]
       [--only paths,burst,...]
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


_PROBE = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], "
          "capture_output=True, text=True); sys.stderr.write(r.stderr[-400:]); "
          "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")


def _peak(args: list[str], cwd: Path) -> tuple[int, float, str]:
    """Exit code, peak RSS (MB, the child's own ``ru_maxrss``) and stderr of a command."""
    r = subprocess.run([PY, "-c", _PROBE, *args], cwd=cwd, capture_output=True, text=True,
                       check=False)
    code, kb = (int(v) for v in r.stdout.split()[-2:])
    return code, kb / 1e3, r.stderr.strip()


def bomb_figures(tmp: Path) -> dict[str, object]:
    """Issue 21, item 3: a compressed bomb per reader -> refused?, peak RSS (MB).

    Real bombs (the data is there, compressed), except the UFF (a sparse file: text is
    not compressed, its size is the bound) and the dense .mat (a declared shape).
    """
    from bombs import (
        csv_of_zeros,
        mat_cell_zeros,
        mat_declaring,
        npz_zeros,
        zip_of_zeros,
    )

    d = tmp / "bombs"
    d.mkdir()
    names = np.array([f"a{i}" for i in range(128)])
    npz = npz_zeros(d / "record.npz", 128, 1 << 20, fs_hz=np.array(100.0), names=names,
                    units=np.array(["g"] * 128), channels=names)  # 1 GiB of zeros
    mat_cell = mat_cell_zeros(d / "cell.mat", 1 << 30)  # 1 GiB of zeros in a cell
    mat_dense = mat_declaring(d / "dense.mat", 20_000, 20_000)
    zipf = zip_of_zeros(d / "record.zip", "CHAN001.V2", 600 << 20)
    csvf = csv_of_zeros(d / "record.csv", 1_100_000, 64)  # 70 M cells, 563 MB as float64
    uff = d / "record.uff"
    with uff.open("wb") as fh:
        fh.truncate((512 << 20) // 4 + 1)
    cli = [PY, "-m", "modal_twin.cli"]
    load = [PY, "-c", "import sys; from modal_twin.excitation.signals import load_record; "
            "load_record(sys.argv[1])"]
    cases = {
        "npz_import": [*cli, "import", str(npz), "--out", str(d / "o1")],
        "npz_matrix_model": [*cli, "model", "info", str(npz)],
        "npz_excitation_record": [*load, str(npz)],
        "mat_cell_matrix_model": [*cli, "model", "info", str(mat_cell)],
        "mat_dense_matrix_model": [*cli, "model", "info", str(mat_dense)],
        "zip_strong_motion_import": [*cli, "import", str(zipf), "--out", str(d / "o2")],
        "csv_import": [*cli, "import", str(csvf), "--fs", "100", "--out", str(d / "o3")],
        "csv_excitation_record": [*load, str(csvf)],
        "uff_import": [*cli, "import", str(uff), "--out", str(d / "o4")],
    }
    fig: dict[str, object] = {"files_bomb_on_disk_mb": {
        k: round(p.stat().st_size / 1e6, 2) for k, p in (
            ("npz", npz), ("mat_cell", mat_cell), ("mat_dense", mat_dense), ("zip", zipf),
            ("csv", csvf))}}
    refused, peaks = {}, {}
    for name, args in cases.items():
        code, mb, err = _peak(args, d)
        refused[name] = code != 0 and "unpack to" in err and "Traceback" not in err
        peaks[name] = round(mb, 1)
    fig["files_bombs_tried"] = len(cases)
    fig["files_bombs_refused"] = sum(refused.values())
    fig["files_bomb_peak_rss_mb"] = peaks
    fig["files_bomb_peak_rss_max_mb"] = max(peaks.values())
    return fig


def damaged_figures(tmp: Path) -> dict[str, object]:
    """Issue 21, item 5: a flipped chunk salvaged, a malformed frame and metrics message.

    - salvage: 825 messages in 17 chunks, 64 bytes flipped in the middle chunk: messages
      kept, messages reported lost, and the silent loss (neither kept nor reported);
    - residual on a 27 s record (403 frames) with one malformed frame in the middle,
      against the truth model of the record: exit code, seconds scored, worst NRMSE;
    - report's metrics with one malformed message among three: the last good one read.
    """
    import struct

    sys.path.insert(0, str(TEST))
    from conftest import write_frames_bag
    from test_damaged_records import _blocks, _chunks, _metrics, _write

    from modal_twin.commands.report import twin_metrics as report_metrics
    from modal_twin.io.bag import BagWriter, read_raw, salvage, scan_mcap
    from modal_twin.io.typestore import typestore
    from modal_twin.models.loading import load_model

    d = tmp / "damaged"
    d.mkdir()
    _write(d / "bag", _blocks(825), flush_every=50, topic="/rig/raw")
    f = next((d / "bag").glob("*.mcap"))
    data = bytearray(f.read_bytes())
    c = _chunks(f)[8]
    for i in range(64):
        data[c + 9 + 300 + i] ^= 0xA5
    f.write_bytes(bytes(data))
    scan = scan_mcap(f)
    kept = salvage(d / "bag").message_count
    fig: dict[str, object] = {"files_salvage_messages": 825, "files_salvage_kept": kept,
                              "files_salvage_reported_lost": scan.lost_messages,
                              "files_salvage_silent_loss": 825 - kept - scan.lost_messages}
    model = TEST.parent / "config" / "structures" / "building.yaml"
    write_frames_bag(d / "good", load_model(model).plant(), seconds=27.0, scale=(0.5,) * 6,
                     seed=3, block=67)
    msgs = list(read_raw(d / "good"))
    sb = "modal_twin_msgs/msg/SignalBlock"
    with BagWriter(d / "bad", {"/measurement/frames": sb}) as w:
        for k, (t, _, ts, raw) in enumerate(msgs):
            w.write(t, ts, raw[:60] if k == len(msgs) // 2 else raw)
    r = subprocess.run([PY, "-m", "modal_twin.cli", "residual", str(model), str(d / "bad"),
                        "--json", str(d / "r.json")], capture_output=True, text=True,
                       check=False)
    table = json.loads((d / "r.json").read_text()) if r.returncode == 0 else {}
    scored = [ln for ln in r.stderr.splitlines() if "scored" in ln]
    fig.update({"files_malformed_frame_frames": len(msgs),
                "files_malformed_frame_residual_exit": r.returncode,
                "files_malformed_frame_scored_s": (
                    float(scored[0].split("scored ")[1].split()[0]) / 1000.0
                    if scored else 0.0),
                "files_malformed_frame_worst_nrmse_pct": round(100 * max(
                    (v["nrmse"] for v in table.values()), default=float("nan")), 6)})
    st = typestore()
    cm = "modal_twin_msgs/msg/ComparisonMetrics"
    with BagWriter(d / "metrics", {"/twin/metrics": cm}) as w:
        w.write("/twin/metrics", 1, st.serialize_cdr(_metrics(st, ["x"], [1.0]), cm))
        w.write("/twin/metrics", 2, struct.pack("<I", 256) + b"garbage")
        w.write("/twin/metrics", 3, st.serialize_cdr(_metrics(st, ["x"], [3.0]), cm))
    m, _ = report_metrics(d / "metrics")
    fig["files_malformed_metrics_report_reads_last_good"] = int(
        m is not None and list(m.rms_error) == [3.0])
    return fig


def _cli(args: list[str], cwd: Path, guard_s: float = 60.0) -> tuple[int | None, str]:
    """Run ``modal-twin args`` in ``cwd``; (exit code or None on a hang, stderr)."""
    env = {**os.environ, "PYTHONPATH": str(TEST.parent)}
    try:
        r = subprocess.run([PY, "-m", "modal_twin.cli", *args], cwd=cwd, env=env,
                           capture_output=True, text=True, timeout=guard_s, check=False)
    except subprocess.TimeoutExpired:
        return None, ""
    return r.returncode, r.stderr


def _tree(root: Path, skip: Path) -> dict[str, int]:
    """Every file under ``root`` but ``skip`` (the run folder): path -> size."""
    return {str(p): p.lstat().st_size for p in root.rglob("*")
            if not p.is_relative_to(skip) and not p.is_dir()}


def paths_figures(tmp: Path) -> dict[str, int]:
    """Issue 21: links, FIFOs, escaping names and existing outputs (module docstring)."""
    import base64

    box = tmp / "paths"
    work = box / "work"  # the working folder; its runs/ is the run folder
    run = work / "runs" / "r1"
    run.mkdir(parents=True)
    building = TEST.parent / "config" / "structures" / "building.yaml"
    secret = b"\x89PNG\r\n\x1a\nSECRET-MARKER-21"
    (box / "secret.png").write_bytes(secret)
    (box / "outside.yaml").write_text(building.read_text())  # a valid structure, outside
    before = _tree(box, work / "runs")
    counts = {"cases": 0, "hangs": 0, "symlink_cases": 0, "symlinks_followed": 0,
              "fifo_cases": 0, "fifo_hangs": 0, "escaped_name_cases": 0,
              "overwrite_cases": 0, "files_overwritten": 0, "tracebacks": 0,
              "multi_line_errors": 0}

    def case(kind: str, args: list[str]) -> None:
        code, err = _cli(args, work)
        counts["cases"] += 1
        counts[f"{kind}_cases"] += 1
        counts["hangs"] += code is None
        if kind == "fifo":
            counts["fifo_hangs"] += code is None
        counts["tracebacks"] += "Traceback" in err
        counts["multi_line_errors"] += code not in (0, None) and len(err.strip().splitlines()) > 1

    # symbolic links: a report figure, a request path, a version's structure
    (run / "leak.png").symlink_to(box / "secret.png")
    (run / "force_state_leak_x.png").symlink_to(box / "secret.png")
    case("symlink", ["--quiet", "report", "runs/r1"])
    page = (run / "report.html").read_text() if (run / "report.html").is_file() else ""
    counts["symlinks_followed"] += base64.b64encode(secret).decode() in page
    (run / "models").mkdir()  # a version naming a link inside to a structure outside
    (run / "models" / "structure.yaml").symlink_to(box / "outside.yaml")
    (run / "models" / "v0001.yaml").write_text("structure: structure.yaml\nversion: 1\n")
    code = (f"from modal_twin.twin.session import TwinSession\n"
            f"t = TwinSession({str(building)!r}, 1000.0, 2.0, 'runs/r1/models')\n"
            f"try:\n    t.load_version('runs/r1/models/v0001.yaml', {{}}, 'v1')\n"
            f"except Exception as e:\n    print('refused')\n")
    counts["cases"] += 1
    counts["symlink_cases"] += 1
    try:
        r = subprocess.run([PY, "-c", code], cwd=work, capture_output=True, text=True,
                           timeout=60, env={**os.environ, "PYTHONPATH": str(TEST.parent)})
        counts["symlinks_followed"] += "refused" not in r.stdout
    except subprocess.TimeoutExpired:
        counts["hangs"] += 1
    # FIFOs where a file is expected
    fifo_dir = work / "runs" / "fifo"
    fifo_dir.mkdir()
    for name in ("x.png", "force_state_fifo_x.png", "m.yaml", "structure.yaml", "s.yaml"):
        os.mkfifo(fifo_dir / name)
    (fifo_dir / "v0001.yaml").write_text(f"structure: {fifo_dir / 'structure.yaml'}\n")
    (fifo_dir / "bag").mkdir()
    (fifo_dir / "bag" / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n"
        "  relative_file_paths: [part.mcap]\n  files: []\n  message_count: 0\n")
    os.mkfifo(fifo_dir / "bag" / "part.mcap")
    for args in (["report", "runs/fifo"], ["model", "info", "runs/fifo/m.yaml"],
                 ["view", "runs/fifo/m.yaml", "--html", "runs/fifo/v.html"],
                 ["view", "runs/fifo/v0001.yaml", "--html", "runs/fifo/v2.html"],
                 ["export", "model", "runs/fifo/m.yaml", "--out", "runs/fifo/o.npz"],
                 ["residual", "runs/fifo/v0001.yaml", "runs/fifo"],
                 ["launch", "runs/fifo/s.yaml"], ["bag", "info", "runs/fifo/bag"],
                 ["identify", "runs/fifo/bag", "--out", "runs/fifo/id"],
                 ["bag", "salvage", "runs/fifo/bag", "--out", "runs/fifo/s"]):
        case("fifo", ["--quiet", *args])
    # names that would move the run folder
    for i, name in enumerate(("x/../../../escaped", "a\\nb", ".hidden", "/abs/x", "..")):
        scen = work / "runs" / f"name{i}.yaml"
        scen.write_text(f'launch: {{name: "{name}", duration_s: 1, '
                        "nodes: [{name: e, executable: excitation_node}]}\n")
        case("escaped_name", ["launch", str(scen)])
    # outputs that exist already
    for args, out in ((["export", "model", str(building), "--out", "runs/o.npz"], "runs/o.npz"),
                      (["report", "runs/r1", "--out", "runs/o.html"], "runs/o.html"),
                      (["view", str(building), "--n-modes", "1", "--html", "runs/v.html"],
                       "runs/v.html"),
                      (["residual", str(building), "runs/none", "--json", "runs/o.json"],
                       "runs/o.json")):
        (work / out).write_text("KEEP")
        case("overwrite", ["--quiet", *args])
        counts["files_overwritten"] += (work / out).read_text(errors="replace") != "KEEP"
    after = _tree(box, work / "runs")
    outside = sum(size for p, size in after.items() if before.get(p) != size)
    return {**{f"paths_{k}": v for k, v in counts.items()},
            "paths_bytes_outside_run_folder": outside}


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
    ap.add_argument("--only", default="", help="comma-separated parts to run (default all)")
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
                       ("bombs", lambda: bomb_figures(tmp)),
                       ("damaged", lambda: damaged_figures(tmp)),
                       ("paths", lambda: paths_figures(tmp)),
                       ("replay_load", lambda: replay_load_figures(tmp))):
        if a.only and name not in a.only.split(","):
            continue
        t0 = time.monotonic()
        part = step()
        fig.update(part)
        print(f"{name}: {part} ({time.monotonic() - t0:.0f} s)", flush=True)
    print(json.dumps(fig))
    return 0


if __name__ == "__main__":
    sys.exit(main())
