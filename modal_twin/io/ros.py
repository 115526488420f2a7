"""rclpy helpers shared by every node: QoS per topic kind, message classes, the main loop."""

from __future__ import annotations

import importlib
import os
import re
import sys
from collections.abc import Callable, Iterator, MutableMapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from modal_twin.errors import ConfigError
from modal_twin.io.topics import BURST_LIMIT_BLOCKS, DEPTH, TOPICS, QosKind
from modal_twin.paths import private_files

__all__ = [
    "BURST_LIMIT_BLOCKS",
    "FASTDDS_PROFILES",
    "compile_kernels",
    "configuring",
    "dds_env",
    "guarded",
    "guarded_service",
    "message_class",
    "one_line",
    "qos_for",
    "qos_profile",
    "report",
    "run_node",
    "split_ros_args",
    "wait_for_subscribers",
]


FASTDDS_PROFILES = Path(__file__).with_name("fastdds_profiles.xml")
"""Fast DDS defaults: UDP on 127.0.0.1 only, unicast discovery on this host, shared memory;
history resource limits above :data:`BURST_LIMIT_BLOCKS`."""
FASTDDS_PROFILES_NETWORK = Path(__file__).with_name("fastdds_profiles_network.xml")
"""The same history limits with Fast DDS's own transports (every interface)."""
_PROFILES_VAR, _RANGE_VAR = "FASTRTPS_DEFAULT_PROFILES_FILE", "ROS_AUTOMATIC_DISCOVERY_RANGE"
_TRANSPORT_VAR = "MODAL_TWIN_TRANSPORT"  # "loopback" / "network", inherited by child processes


def dds_env(env: MutableMapping[str, str], *, network: bool | None = None,
            shared_memory: bool = True, folder: Path | None = None) -> MutableMapping[str, str]:
    """Set the Fast DDS transports of ``env`` (and of the processes started with it).

    Loopback only unless ``network`` (or ``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` in ``env``
    when ``network`` is None): :data:`FASTDDS_PROFILES` with the discovery range
    ``SYSTEM_DEFAULT``, because rmw_fastrtps's ``LOCALHOST`` range adds a UDP transport of its
    own bound to every interface. On a network: :data:`FASTDDS_PROFILES_NETWORK` and
    ``SUBNET``. A profiles file the user set is left alone (the range then defaults to
    ``LOCALHOST``). ``shared_memory=False`` writes the loopback profile without the
    shared-memory transport into ``folder`` (Fast DDS gives its segments mode 0644).
    """
    rng = env.get(_RANGE_VAR, "")
    if network is None:
        network = rng == "SUBNET" or (rng == "SYSTEM_DEFAULT"
                                      and env.get(_TRANSPORT_VAR) != "loopback")
    if env.get(_PROFILES_VAR, "") not in ("", str(FASTDDS_PROFILES),
                                          str(FASTDDS_PROFILES_NETWORK)):
        env.setdefault(_RANGE_VAR, "SUBNET" if network else "LOCALHOST")
        return env
    if network:
        users_own = rng == "SYSTEM_DEFAULT" and env.get(_TRANSPORT_VAR) != "loopback"
        env[_RANGE_VAR] = rng if users_own else "SUBNET"
        env[_PROFILES_VAR], env[_TRANSPORT_VAR] = str(FASTDDS_PROFILES_NETWORK), "network"
        return env
    profile = FASTDDS_PROFILES
    if not shared_memory and folder is not None:
        text = re.sub(r"\s*<transport_id>modal_twin_shm</transport_id>\s*</userTransports>",
                      "\n        </userTransports>", FASTDDS_PROFILES.read_text())
        profile = folder / FASTDDS_PROFILES.name
        profile.write_text(text)
    env[_RANGE_VAR], env[_PROFILES_VAR], env[_TRANSPORT_VAR] = (
        "SYSTEM_DEFAULT", str(profile), "loopback")
    return env


# read when a participant is created (rclpy.init / the first node), so set on import
dds_env(os.environ)



def qos_profile(kind: QosKind) -> QoSProfile:
    """QoS of a topic kind (measured choices, see ../shared/ROS_WHEELS.md).

    Signal blocks: reliable, history :data:`BURST_LIMIT_BLOCKS` deep on both ends, so a
    burst of up to that many blocks that a reader has not yet taken is delivered whole
    (beyond it the oldest are dropped; the readers' stream monitors then log the gap with
    its sample range). Maps and models: reliable + transient local, so late joiners get
    the last one.
    """
    if kind is QosKind.STREAM:
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DEPTH[kind],
                          reliability=ReliabilityPolicy.RELIABLE)
    if kind is QosKind.LATCHED:
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=DEPTH[kind],
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=DEPTH[kind],
        reliability=ReliabilityPolicy.RELIABLE)


def qos_for(topic: str) -> QoSProfile:
    """QoS of a topic of the node graph (stream QoS for topics outside the table)."""
    spec = TOPICS.get(topic)
    return qos_profile(spec.qos if spec else QosKind.STREAM)


def message_class(msgtype: str) -> Any:
    """``pkg/msg/Name`` -> the rclpy message class.

    Raises
    ------
    ConfigError
        If the type is malformed or its package is not built / installed.
    """
    parts = msgtype.split("/")
    if len(parts) != 3 or parts[1] not in {"msg", "srv"}:
        msg = f"message type {msgtype!r}: expected 'package/msg/Name'"
        raise ConfigError(msg)
    try:
        module = importlib.import_module(f"{parts[0]}.{parts[1]}")
        return getattr(module, parts[2])
    except (ImportError, AttributeError) as err:
        msg = f"message type {msgtype!r} is not available to rclpy: {err}"
        raise ConfigError(msg) from err


def split_ros_args(argv: list[str]) -> tuple[list[str], list[str]]:
    """Split ``argv`` into the command's own arguments and the ``--ros-args ...`` tail.

    The tail is empty when there is none, as the launcher starts a command.
    """
    if "--ros-args" not in argv:
        return list(argv), []
    i = argv.index("--ros-args")
    return argv[:i], argv[i:]


def wait_for_subscribers(
    node: Node, publisher: Any, count: int = 1, timeout_s: float = 15.0
) -> bool:
    """Spin ``node`` until ``publisher`` has ``count`` matched readers (discovery ~3 s)."""
    import time

    end = time.monotonic() + timeout_s
    while publisher.get_subscription_count() < count:
        if time.monotonic() > end:
            return False
        rclpy.spin_once(node, timeout_sec=0.05)
    return True


def one_line(err: BaseException, limit: int = 300) -> str:
    """``Type: first line of the message``, cut to ``limit`` characters."""
    text = str(err).strip().splitlines()
    line = f"{type(err).__name__}: {text[0] if text else ''}"
    return line if len(line) <= limit else line[: limit - 3] + "..."


def guarded(node: Node, what: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    """Wrap a subscription or timer callback.

    Any exception is one logged line, and the node keeps running (a hostile message never ends
    a node).
    """

    def call(*args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as err:  # every error: the node must survive any input
            node.get_logger().error(f"{what} refused: {one_line(err)}",
                                    throttle_duration_sec=1.0)
            _count_refused(node)
            return None

    return call


def _count_refused(node: Node) -> None:
    from modal_twin.io.status import status_of

    try:
        status_of(node).count("refused")
    except Exception as err:  # status is a report: it never takes the node down
        node.get_logger().debug(f"status not updated: {one_line(err)}")


def guarded_service(node: Node, what: str, fn: Callable[[Any, Any], Any],
                    ok_field: str = "success") -> Callable[[Any, Any], Any]:
    """Wrap a service callback.

    Any exception answers ``ok_field = False`` with a one-line ``message`` naming the field, is
    logged once, and the node keeps running.
    """

    def call(req: Any, res: Any) -> Any:
        from modal_twin.io.status import status_of

        status = status_of(node)
        status.set("busy", what)
        try:
            out = fn(req, res)
            status.set("ready")
            return out
        except Exception as err:  # every error: the node must survive any request
            text = one_line(err)
            node.get_logger().error(f"{what} refused: {text}")
            setattr(res, ok_field, False)
            res.message = text
            status.count("refused")
            status.set("ready", f"last request refused: {text}")
            return res

    return call


_last_report: dict[tuple[str, str], float] = {}


def report(logger: Any, verdict: Any, *, every_s: float = 1.0, node: Node | None = None
           ) -> None:
    """Log a stream-continuity verdict: an error when the block was dropped, else a warning.

    Throttled per kind of fault (a burst of one fault does not hide another kind).
    rclpy forbids one call site from logging at two severities, hence two sites. A dropped
    block is counted on ``node``'s status (every one, not only the logged ones).
    """
    import time

    if node is not None and verdict.block is None:
        from modal_twin.io.status import status_of

        status_of(node).count("dropped")

    key = (logger.name, verdict.verdict.value)
    now = time.monotonic()
    if now - _last_report.get(key, -1e9) < every_s:
        return
    _last_report[key] = now
    if verdict.block is None:
        logger.error(f"dropped block: {verdict.message}")
    else:
        logger.warning(verdict.message)


@contextmanager
def configuring(node: Node, what: str) -> Iterator[None]:
    """Say on ``/diagnostics`` that ``node`` is still configuring (``starting: <what>``).

    Within the block the status is published once a second from a thread (the node does
    not spin while it builds), so the launcher can name a node that is late and why. The
    launcher starts a run only once every node says ``ready``, which :func:`run_node` sets
    when the node is built.
    """
    import threading

    from modal_twin.io.status import status_of

    status = status_of(node, initial="starting")
    status.set("starting", what)
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(1.0):
            try:
                status.publish()
            except Exception:  # a report only: never in the way of the start
                return

    thread = threading.Thread(target=beat, name="status", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def compile_kernels(node: Node, *warm: Callable[[], object]) -> float:
    """Compile a node's numba kernels while it configures, before it reports ready.

    Each of ``warm`` runs the kernels once (e.g.
    :meth:`modal_twin.twin.simulator.Simulator.warm_up`). The node says ``starting:
    compiling kernels`` on ``/diagnostics`` meanwhile and logs ``compiling kernels ... done
    in X s`` (tens of seconds on a cold numba cache, about a second from the disk cache), so
    that no block of the run waits for a compiler. Returns the seconds taken.
    """
    import time

    node.get_logger().info("compiling kernels ...")
    t0 = time.perf_counter()
    with configuring(node, "compiling kernels"):
        for fn in warm:
            fn()
    took = time.perf_counter() - t0
    node.get_logger().info(f"compiling kernels ... done in {took:.1f} s")
    return took


def run_node(factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Create the node, spin it, shut down cleanly on Ctrl-C / SIGTERM / shutdown.

    Returns the process exit code (0, or 1 if the node raised).
    """
    node: Node | None = None
    code = 0
    private_files()  # what a node writes is private to its user (README: file modes)
    try:
        rclpy.init(args=args if args is not None else sys.argv)
        node = factory()
        from modal_twin.io.status import status_of

        status_of(node).set("ready")  # built and warmed: ready, on /diagnostics
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as err:
        if node is not None:
            node.get_logger().fatal(f"{type(err).__name__}: {err}")
        else:
            print(f"node failed to start: {type(err).__name__}: {err}", file=sys.stderr)
        code = 1
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if callable(close):  # what it writes at the end may set its exit code
                try:
                    close()
                except Exception as err:  # said in one line, never a traceback
                    node.get_logger().error(f"closing: {type(err).__name__}: {err}")
                    code = 1
            code = code or int(getattr(node, "exit_code", 0))
            node.destroy_node()
        rclpy.try_shutdown()
    return code
