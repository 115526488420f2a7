"""One ``identify_record``: the CLI, the node's call and a campaign window give the same modes.

The record is a three-storey shear frame on a measured base acceleration (exact
frequencies from its matrices), with a reference channel (a drifting temperature-like
signal) that is neither input nor output, named so that no name rule could find the
roles: only the channel map says what is what.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.channels import ChannelSpec
from modal_twin.cli import main
from modal_twin.errors import ConfigError, OptionError
from modal_twin.exit_codes import ExitCode
from modal_twin.identification.campaign import WindowIdentifier, split_windows
from modal_twin.identification.record import IdentifyOptions, identify_record
from modal_twin.identification.window import IdentificationConfig, identify_window
from modal_twin.signal_block import SignalBlock

MASS = np.array([2000.0, 1800.0, 1500.0])
K = np.array([4.0e6, 3.0e6, 2.0e6])
FS, SECONDS = 100.0, 200.0
NAMES = ("ch_a", "ch_b", "ch_c", "ch_d", "ch_e")  # base, floors 1-3, reference
ROLES = ("input", "output", "output", "output", "reference")


def _stiffness() -> np.ndarray:
    k = np.r_[K, 0.0]
    return np.diag(k[:-1] + k[1:]) - np.diag(K[1:], 1) - np.diag(K[1:], -1)


def exact_f_hz() -> np.ndarray:
    """Undamped frequencies of the frame (the truth)."""
    return np.sqrt(sla.eigh(_stiffness(), np.diag(MASS), eigvals_only=True)) / (2 * np.pi)


def frame_record() -> tuple[SignalBlock, list[ChannelSpec]]:
    """Base acceleration in, absolute floor accelerations out (2 % damping, 2 % noise)."""
    M, Kk = np.diag(MASS), _stiffness()
    w2, V = sla.eigh(Kk, M)
    C = M @ V @ np.diag(2 * 0.02 * np.sqrt(w2)) @ V.T @ M
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Mi @ Kk, -Mi @ C]])
    B = np.vstack([np.zeros((3, 1)), -np.ones((3, 1))])
    Cy = np.hstack([-Mi @ Kk, -Mi @ C])
    sysd = sig.cont2discrete((A, B, Cy, np.zeros((3, 1))), 1 / FS)
    rng = np.random.default_rng(11)
    ag = rng.standard_normal(int(FS * SECONDS))
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), ag)
    y = y.T + 0.02 * y.std(axis=0)[:, None] * rng.standard_normal(y.T.shape)
    ref = np.cumsum(rng.standard_normal(ag.size)) * 1e-3
    data = np.vstack([ag, y, ref])
    chans = [ChannelSpec(n, "acceleration", direction="x", role=r, node=f"n{k}")
             for k, (n, r) in enumerate(zip(NAMES, ROLES, strict=True))]
    return SignalBlock(NAMES, FS, 0, data, stamp_ns=10**18, source="frame"), chans


@pytest.fixture(scope="module")
def record() -> tuple[SignalBlock, list[ChannelSpec]]:
    return frame_record()


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory, record) -> Path:  # type: ignore[no-untyped-def]
    from modal_twin.io.imported import write_imported

    block, chans = record
    return write_imported(tmp_path_factory.mktemp("rec") / "bag", block, chans)


def _node_view(bag: Path) -> tuple[SignalBlock, list[ChannelSpec]]:
    """What the node holds: the frames joined, the map of /measurement/channels."""
    from modal_twin.io.bag import read_blocks, read_messages
    from modal_twin.io.convert import channel_map_from_msg
    from modal_twin.signal_block import concatenate_blocks

    msgs = [m for _, _, m in read_messages(bag, ["/measurement/channels"])]
    return (concatenate_blocks(read_blocks(bag, "/measurement/frames")),
            channel_map_from_msg(msgs[0]))


@pytest.mark.parametrize("method", ["n4sid", "ssi-cov"])
def test_cli_node_and_campaign_give_the_same_modes(bag: Path, tmp_path: Path,
                                                  method: str) -> None:
    from modal_twin.io.modes_file import read_modes

    assert main(["identify", str(bag), "--method", method, "--out", str(tmp_path)]) == 0
    cli = read_modes(tmp_path / "modes.json")
    block, chans = _node_view(bag)
    node = identify_window(block, IdentificationConfig(method=method), chans)
    assert node.output_names == ("ch_b", "ch_c", "ch_d")  # by role: not the reference
    assert [c.name for c in node.inputs] == ([] if method == "ssi-cov" else ["ch_a"])
    win = split_windows(block, SECONDS, outputs=node.output_names,
                        inputs=() if method == "ssi-cov" else ("ch_a",))
    camp = WindowIdentifier(method=method, orders=None)(win[0])
    np.testing.assert_array_equal(node.modes.f_hz, cli.f_hz)
    np.testing.assert_array_equal(node.modes.zeta, cli.zeta)
    np.testing.assert_array_equal(node.modes.shapes, cli.shapes)
    # the campaign skips the standard deviations (speed): the same poles to round-off
    np.testing.assert_allclose(camp.f_hz, cli.f_hz, rtol=1e-10)
    np.testing.assert_allclose(camp.shapes, cli.shapes, rtol=1e-6, atol=1e-8)
    lo, hi = node.settings.band_hz
    f_true = exact_f_hz()[(exact_f_hz() > lo) & (exact_f_hz() < hi)]
    assert f_true.size >= 2
    near = np.array([np.argmin(np.abs(cli.f_hz - f)) for f in f_true])
    np.testing.assert_allclose(cli.f_hz[near], f_true, rtol=0.01)
    np.testing.assert_allclose(cli.zeta[near], 0.02, rtol=0.35)
    if method == "n4sid":
        assert cli.f_hz.size == f_true.size


def test_default_method_and_polymax_on_every_path(record) -> None:  # type: ignore[no-untyped-def]
    block, chans = record
    rec = identify_record(block, chans)
    assert rec.method == "n4sid"
    assert any("method n4sid: 1 driven inputs" in n for n in rec.notes)
    cfg = IdentificationConfig(method="polymax")
    pm = identify_window(block, cfg, chans)
    assert pm.method == "polymax"
    f_true = exact_f_hz()[exact_f_hz() < pm.settings.band_hz[1]]
    np.testing.assert_allclose(pm.modes.f_hz, f_true, rtol=0.01)
    out_only = identify_record(block, [c.with_role("reference") if c.role == "input" else c
                                       for c in chans])
    assert out_only.method == "ssi-cov"
    assert any("no driven input, output-only" in n for n in out_only.notes)


def test_relaxed_fallback_reaches_the_node(record) -> None:  # type: ignore[no-untyped-def]
    """Thresholds nothing meets: every path retries with the relaxed ones and says so."""
    block, chans = record
    tight = {"rel_tol_f": 1e-12, "rel_tol_zeta": 1e-12, "mac_min": 1.0}
    rec = identify_record(block, chans, IdentifyOptions(thresholds=tight,
                                                        selection="stability"))
    node = identify_window(block, IdentificationConfig(rel_tol_f=1e-12, rel_tol_zeta=1e-12,
                                                       mac_min=1.0, selection="stability"),
                           chans)
    assert rec.relaxed and node.relaxed
    assert any("relaxed" in n for n in node.notes)
    np.testing.assert_array_equal(rec.modes.f_hz, node.modes.f_hz)
    assert rec.diagram.rel_tol_f == 0.02
    none = identify_record(block, chans, IdentifyOptions(thresholds=tight, relax=False,
                                                         selection="stability"))
    assert none.modes.f_hz.size == 0 and not none.relaxed


def test_one_spelling_of_each_method(bag: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(OptionError, match="method: expected one of"):
        IdentifyOptions(method="ssi_cov")
    with pytest.raises(ConfigError, match="method: expected one of"):
        IdentificationConfig(method="ssi_cov")
    with pytest.raises(OptionError, match="method: expected one of"):
        WindowIdentifier(method="ssi_cov")
    with pytest.raises(SystemExit):
        main(["identify", str(bag), "--method", "ssi_cov"])
    assert "invalid choice: 'ssi_cov'" in capsys.readouterr().err


def test_names_replace_roles_and_unknown_names_are_named(record) -> None:  # type: ignore[no-untyped-def]
    block, chans = record
    rec = identify_record(block, chans, IdentifyOptions(method="ssi-cov",
                                                        outputs=("ch_c", "ch_d")))
    assert rec.output_names == ("ch_c", "ch_d")
    with pytest.raises(OptionError, match=r"outputs: channels \['zz'\] not in the record"):
        identify_record(block, chans, IdentifyOptions(outputs=("zz",)))
    no_out = [c.with_role("reference") if c.role == "output" else c for c in chans]
    with pytest.raises(OptionError, match="no channel with role 'output'"):
        identify_record(block, no_out)


def test_options_the_record_cannot_support_are_errors(bag: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    for f_max, limit in (("500", "(0, 40] Hz (0.8 x the Nyquist frequency of 100 Hz)"),
                         ("-5", "(0, 40] Hz")):
        assert main(["identify", str(bag), "--f-max", f_max]) == ExitCode.USAGE
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"--f-max: expected a frequency in {limit}" in err[0]


def test_a_stable_column_outside_the_band_is_named(record) -> None:  # type: ignore[no-untyped-def]
    block, chans = record
    rec = identify_record(block, chans, IdentifyOptions(method="n4sid", f_max_hz=9.0))
    np.testing.assert_allclose(rec.modes.f_hz, exact_f_hz()[:2], rtol=0.01)
    third = [d for d in rec.dropped if abs(d.f_hz / exact_f_hz()[2] - 1) < 0.01]
    assert len(third) == 1, [d.describe() for d in rec.dropped]
    assert third[0].reason == "outside the band 0.1-9 Hz"
    assert third[0].n_poles >= 10
    assert "11.1" in third[0].describe() and "outside the band" in third[0].describe()


def test_output_only_polymax_from_half_spectra(record) -> None:  # type: ignore[no-untyped-def]
    """No input: PolyMAX on the positive half-spectra finds every mode, LSFD shapes."""
    block, chans = record
    rec = identify_record(block, chans, IdentifyOptions(method="polymax", inputs=(),
                                                        f_max_hz=14.0))
    assert rec.inputs == ()
    assert any("positive half-spectra" in n for n in rec.notes)
    np.testing.assert_allclose(rec.modes.f_hz, exact_f_hz(), rtol=0.01)
    # output-only damping of this 200 s record: SSI-cov gives 1.5-1.7 % (truth 2 %)
    np.testing.assert_allclose(rec.modes.zeta, 0.02, rtol=0.5)
    io = identify_record(block, chans, IdentifyOptions(method="n4sid", f_max_hz=14.0))
    from modal_twin.identification import mac

    pair = [int(np.argmin(np.abs(io.modes.f_hz - f))) for f in rec.modes.f_hz]
    assert np.diag(mac(rec.modes.shapes, io.modes.shapes[:, pair])).min() > 0.99


def test_default_method_follows_the_coherence(record) -> None:  # type: ignore[no-untyped-def]
    """An 'input' that does not drive the response (independent noise): output-only."""
    block, chans = record
    data = block.data.copy()
    data[0] = np.random.default_rng(3).standard_normal(data.shape[1])
    rec = identify_record(SignalBlock(block.channel_names, FS, 0, data), chans)
    assert rec.method == "ssi-cov" and rec.inputs == ()
    assert any("mean coherence" in n and "output-only" in n for n in rec.notes)
    rec = identify_record(block, chans)
    assert rec.method == "n4sid"
    assert any("mean coherence 0.9" in n for n in rec.notes)


def test_the_spectrum_behind_the_diagram_peaks_at_the_modes(record) -> None:  # type: ignore[no-untyped-def]
    block, chans = record
    rec = identify_record(block, chans, IdentifyOptions(method="ssi-cov", f_max_hz=14.0))
    assert rec.spectrum is not None
    f, sv = rec.spectrum
    assert sv.shape == (3, f.size) and np.all(sv[0] >= sv[1])
    for fk in exact_f_hz():
        win = (f > 0.97 * fk) & (f < 1.03 * fk)
        peak = f[win][np.argmax(sv[0][win])]
        assert abs(peak / fk - 1) < 0.02  # inside the half-power band (2 % damping)


def test_record_limits_are_errors_naming_them(record) -> None:  # type: ignore[no-untyped-def]
    from modal_twin.identification.record import welch_segment

    block, chans = record
    with pytest.raises(OptionError, match=r"--f-max: expected a frequency in \(0, 40\] Hz"):
        identify_record(block, chans, IdentifyOptions(f_max_hz=float("nan")))
    with pytest.raises(OptionError, match="band: expected the lower edge 5 Hz"):
        identify_record(block, chans, IdentifyOptions(f_min_hz=5.0, f_max_hz=4.0))
    short = SignalBlock(block.channel_names, FS, 0, block.data[:, :40])
    with pytest.raises(OptionError, match=r"record: expected at least 0.5 s .* got 0.4 s"):
        identify_record(short, chans)
    # H1 blocks from the record: the longest power of two with 2 n_in + 2 averages
    assert welch_segment(4333, 6) == 512
    assert 2 * 4333 // 512 - 1 >= 2 * 6 + 2
    assert welch_segment(20000, 1) == 4096


# ---------------------------------------------------------------- real records
REAL = Path(__file__).resolve().parents[3] / "shared" / "realdata" / "earthquakes"
if not REAL.is_dir():
    REAL = Path("/work/shared/realdata/earthquakes")
HAYWARD_MAP = Path(__file__).resolve().parents[2] / "config" / "channel_maps" / \
    "csmip58658_hayward.yaml"


def _real_record(name: str, tmp: Path, *extra: str):  # type: ignore[no-untyped-def]
    from modal_twin.io.imported import read_imported

    z = REAL / name
    if not z.is_file():
        pytest.skip(f"{z} absent")
    assert main(["import", str(z), "--out", str(tmp / name), *extra]) == 0
    return read_imported(tmp / name)


def test_hayward_events_comparable_bands_and_every_column_said(tmp_path: Path) -> None:
    """Both events: the six ground channels explain 64-65 % of the response (debiased
    coherence, below 0.8), so the default is SSI-cov, said; the same decimation and block
    rows (bands 39.3 / 32.2 Hz); 2021-04-26's three first modes within 0.5 % of what FDD
    and a plain SSI-cov agree on (1.756, 2.493, 3.343 Hz; N4SID's first mode was 3.274 Hz,
    2 % off). By N4SID the 5.35 Hz column of 2021-11-17, stable from order 8 to 60 but
    dropped by the [004] rule, is a mode of the clustering (issue 22: pyOMA2 5.34-5.37 Hz),
    and the earlier rule still names it with its reason."""
    data = [_real_record(f"csmip58658_hayward_bridge_{e}.zip", tmp_path, "--map",
                         str(HAYWARD_MAP)) for e in ("2021-04-26", "2021-11-17")]
    recs = [identify_record(*d) for d in data]
    (a, b) = (r.settings for r in recs)
    assert (a.factor, a.block_rows) == (b.factor, b.block_rows) == (2, 82)
    assert 0.75 < b.band_hz[1] / a.band_hz[1] < 1.0  # 39.3 and 32.2 Hz
    assert all(r.method == "ssi-cov" and "mean coherence 0.6" in r.notes[0]
               and "output-only" in r.notes[0] for r in recs), [r.notes[0] for r in recs]
    f0 = recs[0].modes.f_hz
    for fa in (1.756, 2.493, 3.343):
        assert np.min(np.abs(f0 / fa - 1)) < 0.005, f0
    n4 = identify_record(*data[1], IdentifyOptions(method="n4sid"))
    assert n4.settings.block_rows == 80
    assert np.min(np.abs(n4.modes.f_hz - 5.36)) < 0.02, n4.modes.f_hz
    assert all(d.reason for d in recs[1].dropped) and all(d.reason for d in n4.dropped)
    old = identify_record(*data[1], IdentifyOptions(method="n4sid", selection="stability"))
    col = [d for d in old.dropped if abs(d.f_hz - 5.35) < 0.03]
    assert len(col) == 1 and "stable in frequency at" in col[0].reason, \
        [d.describe() for d in old.dropped]


def test_berkeley_two_modes_and_the_1_6_hz_column_said(tmp_path: Path) -> None:
    block, chans = _real_record("nsmp1103_berkeley_building_2018-01-04.zip", tmp_path)
    rec = identify_record(block, chans, IdentifyOptions(directions=("x", "y")))
    # the basement channels are coherent with the roof (0.96) but fed back by it (the
    # building on its soil): output-only, said; its two first modes lie within 0.6 % of
    # the plain SSI-cov columns of the reference (1.025, 1.237 Hz)
    assert rec.method == "ssi-cov" and any("fed back" in n for n in rec.notes)
    assert any("fed back by the structure" in w for w in rec.warnings)
    np.testing.assert_allclose(rec.modes.f_hz[:2], [1.023, 1.244], atol=0.002)
    # input-output from the basement: the fixed-base building, 2 % higher; the 1.60 Hz
    # column issue 22 names, split by the order (3 poles at 1.595 Hz, then 6 at 1.583 Hz,
    # less damped), is one mode; the clustering adds a 9.24 Hz cluster of 11 poles (MPC
    # 0.31: complex; the references see FDD peaks at 9.08 / 9.43 Hz, SSI columns at 8.97)
    io = identify_record(block, chans, IdentifyOptions(directions=("x", "y"), method="n4sid"))
    np.testing.assert_allclose(io.modes.f_hz[:3], [1.044, 1.265, 1.583], atol=0.002)
    assert io.modes.n_support[2] == 9
    assert io.modes.f_hz.size <= 4 and np.all(io.modes.f_hz[3:] > 9.0)
    oo = identify_record(block, chans, IdentifyOptions(method="polymax", inputs=()))
    assert any("positive half-spectra" in n for n in oo.notes)
    assert np.min(np.abs(oo.modes.f_hz - 1.248)) < 0.01  # the second mode, output-only
    # the map's 6 ground inputs: coherent, but fed back by the building (and 41 s would
    # give H1 lines 0.31 Hz apart, too coarse for a 1 %-damped mode): output-only, said,
    # the same modes
    pm = identify_record(block, chans, IdentifyOptions(method="polymax"))
    assert pm.inputs == () and any("PolyMAX output-only" in n and "fed back" in n
                                   for n in pm.notes)
    np.testing.assert_allclose(pm.modes.f_hz, oo.modes.f_hz)


def test_cli_prints_the_clustering_and_keeps_the_old_rule_on_request(  # type: ignore[no-untyped-def]
        bag: Path, capsys) -> None:
    assert main(["identify", str(bag), "--method", "n4sid"]) == 0
    out = capsys.readouterr().out
    assert "modes by clustering the poles of 30 orders: cut-off distance" in out
    lines = out.splitlines()
    head = next(k for k, ln in enumerate(lines) if ln.startswith("mode    f [Hz]"))
    rows = [ln.split() for ln in lines[head + 1:] if ln[:4].strip().isdigit()]
    f = np.array([float(r[1]) for r in rows])
    np.testing.assert_allclose(f, exact_f_hz(), rtol=0.01)  # every mode, nothing else
    assert all(int(r[-1]) >= 20 for r in rows)  # cluster sizes of 30 orders
    if "not reported:" in out:
        assert "f [Hz] zeta [%] poles  orders  reason" in out
    assert main(["identify", str(bag), "--method", "n4sid", "--selection", "stability"]) == 0
    assert "modes by clustering" not in capsys.readouterr().out


def test_coherence_of_unrelated_inputs_is_debiased_to_zero() -> None:
    """Six inputs unrelated to the outputs over a short record (24 averages): the raw
    multiple coherence is about 6 / 24 = 0.25 (measured on Hayward with noise inputs:
    0.26); less that bias it is near 0, and outputs made from the inputs stay near 1."""
    from modal_twin.acquisition.frf import frf
    from modal_twin.identification.record import _coherence, welch_segment

    rng = np.random.default_rng(5)
    u = rng.standard_normal((6, 6500))
    y = rng.standard_normal((4, 6500))
    est = frf(u, y, 100.0, nperseg=welch_segment(6500, 6))
    assert est.n_averages == 24
    assert 0.2 < float(est.coherence[:, 1:].mean()) < 0.3
    assert _coherence(u, y, 100.0, (1.0, 40.0)) < 0.05
    driven = sig.lfilter([1.0], [1.0, -1.2, 0.5], rng.standard_normal((4, 6)) @ u, axis=1)
    assert _coherence(u, driven + 0.01 * y, 100.0, (1.0, 40.0)) > 0.95


def test_ssi_scales_channels_of_one_quantity_jointly_unless_far_apart() -> None:
    from modal_twin.identification.record import JOINT_SCALE, scale_groups

    rng = np.random.default_rng(0)
    e = rng.standard_normal((5, 4000))
    gains = np.array([1.0, 0.5, 0.2, 3.0, 0.01])  # three accelerations x5 apart; two strains
    y = gains[:, None] * e / e.std(axis=1, keepdims=True)
    q = ["acceleration"] * 3 + ["strain"] * 2
    labels, note = scale_groups(y, q)
    # accelerations: spread x5 <= x10, one scale; strains: x300 > x10, each its own
    assert labels[:3] == ["acceleration"] * 3
    assert labels[3] != labels[4] and all(lab.startswith("strain") for lab in labels[3:])
    assert "3 acceleration channels scaled jointly (RMS spread x5.0, <= x10)" in note
    assert "2 strain channels each to unit RMS (RMS spread x300.0, > x10)" in note
    assert JOINT_SCALE == 10.0
    # the boundary: exactly x10 is joint, just above it is not
    y2 = np.array([[1.0, -1.0] * 50, [10.0, -10.0] * 50, [10.01, -10.01] * 50])
    assert scale_groups(y2[:2], ["a", "a"])[0] == ["a", "a"]
    assert len(set(scale_groups(y2[[0, 2]], ["a", "a"])[0])) == 2
