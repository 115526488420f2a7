from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError
from modal_twin.io.tabular import read_csv, read_npz


def test_csv_units_in_brackets_and_second_row(tmp_path: Path) -> None:
    p = tmp_path / "a.csv"
    p.write_text("t [s], a1 [g], F [kN]\n0.0, 1.0, 2.0\n0.01, 0.5, 1.0\n0.02, 0.0, 0.0\n")
    chans, fs, X = read_csv(p)
    assert fs == pytest.approx(100.0)
    assert [(c.name, c.quantity, c.unit) for c in chans] == [("a1", "acceleration", "m/s^2"),
                                                              ("F", "force", "N")]
    np.testing.assert_allclose(X, [[9.80665, 4.903325, 0.0], [2000.0, 1000.0, 0.0]])
    q = tmp_path / "b.csv"
    q.write_text("a1,a2\nm/s^2,mm/s^2\n1,1000\n2,2000\n")
    chans, fs, X = read_csv(q, fs_hz=50.0)
    assert fs == 50.0
    np.testing.assert_allclose(X, [[1.0, 2.0], [1.0, 2.0]])


def test_csv_errors(tmp_path: Path) -> None:
    p = tmp_path / "x.csv"
    p.write_text("t,a1\n0,1\n0.1,2\n")
    with pytest.raises(ConfigError, match=r"x\.csv: CSV without units"):
        read_csv(p)
    p.write_text("t [s], a1 [m/s^2], a2 [m/s^2]\n0,1,2\n0.1,2\n")
    with pytest.raises(ConfigError, match=r"row 3 has 2 \(missing columns\)"):
        read_csv(p)
    p.write_text("t [s], a1 [furlong]\n0,1\n0.1,2\n")
    with pytest.raises(ConfigError, match="unit 'furlong'"):
        read_csv(p)
    p.write_text("t [s], a1 [m/s^2]\n0,1\n0.1,2\n0.3,2\n")
    with pytest.raises(ConfigError, match="not uniformly increasing"):
        read_csv(p)
    p.write_text("a1 [m/s^2]\n1\n2\n")
    with pytest.raises(ConfigError, match="give the sample rate"):
        read_csv(p)


def test_npz_record(tmp_path: Path) -> None:
    p = tmp_path / "r.npz"
    np.savez(p, data=np.ones((2, 5)), fs_hz=200.0, names=np.array(["u", "y"]),
             units=np.array(["g", "m/s^2"]), roles=np.array(["input", "output"]))
    chans, fs, X = read_npz(p)
    assert fs == 200.0
    assert [c.role for c in chans] == ["input", "output"]
    np.testing.assert_allclose(X[0], 9.80665)
    np.savez(p, data=np.ones((2, 5)), fs_hz=200.0, names=np.array(["u", "y"]))
    with pytest.raises(ConfigError, match=r"lacks arrays \['units'\]"):
        read_npz(p)
