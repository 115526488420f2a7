"""Figure modules: content checked on the artists (values, counts, labels), not files."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ShapeError
from modal_twin.identification.modal_model import PoleSet, StabilizationDiagram
from modal_twin.viz._figure import channel_parts, png_bytes
from modal_twin.viz.error_history import error_history_figure
from modal_twin.viz.evidence import plot_amplitude_dependence, plot_force_state_surface
from modal_twin.viz.frf import plot_frf_overlay
from modal_twin.viz.hysteresis import plot_hysteresis
from modal_twin.viz.mac import plot_mac
from modal_twin.viz.modes_table import modes_table_html
from modal_twin.viz.stabilization import plot_stabilization
from modal_twin.viz.where import plot_where, where_table_html


def test_mac_identity_writes_its_diagonal() -> None:
    fig = plot_mac(np.eye(3), ["a", "b", "c"], ["1", "2", "3"])
    texts = [t for t in fig.axes[0].texts]
    assert len(texts) == 9
    for t in texts:
        j, i = t.get_position()
        assert t.get_text() == ("1.00" if i == j else "0.00")
    assert png_bytes(fig)[:8] == b"\x89PNG\r\n\x1a\n"


def test_mac_label_mismatch_raises() -> None:
    with pytest.raises(ShapeError, match=r"mac: expected \(n_row, n_col\) = \(2, 3\)"):
        plot_mac(np.eye(3), ["a", "b"], ["1", "2", "3"])


def _diagram() -> StabilizationDiagram:
    def ps(order: int, f: list[float]) -> PoleSet:
        n = len(f)
        return PoleSet(order, np.array(f), np.full(n, 0.02), np.ones((2, n), complex),
                       np.full(n, np.nan), np.full(n, np.nan))

    poles = (ps(4, [1.0, 2.0]), ps(6, [1.0, 2.0, 3.3]), ps(8, [1.0, 2.0, 3.0]))
    stable_f = (np.array([True, True]), np.array([True, True, False]),
                np.array([True, False, False]))
    stable = (np.array([True, False]), np.array([True, False, False]),
              np.array([False, False, False]))
    return StabilizationDiagram("ssi-cov", np.array([4, 6, 8]), poles, stable_f, stable_f,
                                stable_f, stable, 0.01, 0.05, 0.95)


def test_stabilization_marks_each_class() -> None:
    fig = plot_stabilization(_diagram(), selected_f_hz=[1.0])
    other, freq, stable = fig.axes[0].collections
    assert sorted(map(tuple, stable.get_offsets().tolist())) == [(1.0, 4.0), (1.0, 6.0)]
    assert sorted(map(tuple, freq.get_offsets().tolist())) == [(1.0, 8.0), (2.0, 4.0),
                                                               (2.0, 6.0)]
    assert len(other.get_offsets()) == 3
    assert fig.axes[0].get_legend() is not None


def test_channel_parts() -> None:
    assert channel_parts("F0_C1_x") == ("F0", "x", "acceleration")
    assert channel_parts("ESB1_dx") == ("ESB1", "x", "drift")
    assert channel_parts("ESB1_fy") == ("ESB1", "y", "force")


def test_where_groups_mean_and_max() -> None:
    names = ["F1_C1_x", "F1_C2_x", "F2_C1_y", "ESB1_fx"]
    fig = plot_where(names, [1.0, 3.0, 10.0, 5.0])
    ax_place = fig.axes[0]
    labels = [t.get_text() for t in ax_place.get_xticklabels()]
    heights = dict(zip(labels, [p.get_height() for p in ax_place.patches], strict=True))
    assert heights == {"ESB1": 5.0, "F1": 2.0, "F2": 10.0}
    html = where_table_html(names, [1.0, 3.0, 10.0, 5.0], top=2)
    assert html.index("F2_C1_y") < html.index("ESB1_fx") and "F1_C1_x" not in html
    with pytest.raises(ShapeError, match="errors: expected 4 values"):
        plot_where(names, [1.0])


def test_error_history_groups_by_direction_and_quantity() -> None:
    errs = [{f"F{k}_C1_{d}": 10.0 * (k + 1) for k in range(6) for d in "xyz"}
            | {"ESB1_dx": 4.0}, {f"F{k}_C1_{d}": 0.1 for k in range(6) for d in "xyz"}
            | {"ESB1_dx": 0.04}]
    fig = error_history_figure(["v0", "v1"], errs)
    titles = sorted(a.get_title() for a in fig.axes if a.get_visible())
    assert titles == ["acceleration x (6 channels)", "acceleration y (6 channels)",
                      "acceleration z (6 channels)", "drift x (1 channels)"]
    ax = next(a for a in fig.axes if a.get_title().startswith("acceleration x"))
    median = next(ln for ln in ax.lines if ln.get_label() == "median")
    assert median.get_ydata().tolist() == pytest.approx([35.0, 0.1])
    assert len(fig.legends) == 1  # one legend, outside the panels


def test_frf_overlay_shows_worst_channels_first() -> None:
    f = np.linspace(0.5, 20.0, 50)
    H = np.ones((30, f.size), complex)
    Hp = H.copy()
    Hp[[3, 17]] *= 10.0  # the two misfitting channels
    names = [f"ch{i}" for i in range(30)]
    fig = plot_frf_overlay(f, H, names, Hp, max_panels=2)
    assert [a.get_title() for a in fig.axes if a.get_visible()] == ["ch3", "ch17"]
    with pytest.raises(ShapeError, match="H_model: expected"):
        plot_frf_overlay(f, H, names, Hp[:2])


def test_modes_table_frequency_error_and_bad_pair() -> None:
    html = modes_table_html([1.1, 2.0], [0.02, 0.03], f_model_hz=[1.0, 2.0],
                            zeta_model=[0.02, np.nan], mac=[0.99, 0.5])
    assert "+10.00" in html and "<tr class=\"bad\">" in html and "&ndash;" in html
    with pytest.raises(ShapeError, match="mac: expected 2 values"):
        modes_table_html([1.0, 2.0], [0.0, 0.0], mac=[1.0])


def test_hysteresis_units_and_model_overlay() -> None:
    u = 0.01 * np.sin(np.linspace(0, 6.28, 100))
    fig = plot_hysteresis({"ESB1 x": (u, 1e4 * u)}, {"ESB1 x": (u, 2e4 * u)})
    meas, model = fig.axes[0].lines
    assert np.max(meas.get_xdata()) == pytest.approx(10.0, rel=1e-3)  # mm
    assert np.max(model.get_ydata()) == pytest.approx(0.2, rel=1e-3)  # kN


def test_evidence_plots() -> None:
    u = np.linspace(-1, 1, 10)
    fig = plot_force_state_surface(u, u, u)
    assert len(fig.axes[0].collections[0].get_offsets()) == 10
    fig2 = plot_amplitude_dependence([0.002, 0.001], [5.0, 1.0], [1e6, 2e6])
    assert fig2.axes[0].lines[0].get_xdata().tolist() == [1.0, 2.0]  # sorted, mm
    with pytest.raises(ShapeError, match="expected equal lengths"):
        plot_force_state_surface(u, u[:3], u)
