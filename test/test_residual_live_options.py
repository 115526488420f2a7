"""``modal-twin residual --live --stall``: checked before any work, and handed to the replay."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import modal_twin.commands.residual as residual
from modal_twin.cli import main
from modal_twin.errors import LaunchError
from modal_twin.exit_codes import ExitCode


@pytest.mark.parametrize("stall", ["0", "nan", "-5", "1e9"])
def test_a_stall_outside_its_range_is_one_line_and_a_usage_exit(
        stall: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = main(["residual", "building.yaml", str(tmp_path / "absent_bag"), "--live",
                 "--stall", stall])
    err = capsys.readouterr().err.strip()
    assert code == ExitCode.USAGE
    assert err.count("\n") == 0 and err.startswith("modal-twin residual: --stall ")
    assert "outside [1, 3600] s" in err


def test_the_stall_is_handed_to_the_replay_node(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[Any] = []

    class StopHereError(LaunchError):
        pass

    def launcher(sc: Any, **kw: Any) -> None:
        seen.append(sc)
        msg = "stop here"
        raise StopHereError(msg)

    monkeypatch.setattr(residual, "record_span", lambda bag: (0, 99, 100))
    monkeypatch.setattr("modal_twin.launch.Launcher", launcher)
    with pytest.raises(StopHereError):
        residual.replay_into_twin(Path("m.yaml"), Path("b"), rate=4.0, run_dir=None,
                                  fs_hz=100.0, stall_s=7.5)
    (replay,) = [n for n in seen[0].nodes if n.name == "replay"]
    args = list(replay.args)
    assert args[args.index("--stall") + 1] == "7.5"
    assert args[args.index("--paced-by") + 1] == "/twin/residual"
