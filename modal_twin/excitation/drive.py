"""Excitation plan: what to drive, generated up front and cut into blocks on demand."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.excitation import signals

__all__ = ["KINDS", "TRACK_CHANNELS", "TRACK_CHANNELS_3D", "ExcitationConfig", "make_drive"]

KINDS = ("random", "chirp", "multisine", "earthquake", "record", "track", "impact")
TRACK_CHANNELS = ("zt1", "zt2", "zt3", "zt4", "vt1", "vt2", "vt3", "vt4")
TRACK_CHANNELS_3D = tuple(
    [f"{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)]
    + [f"d{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)])
"""The 3D car's track inputs (a ``kind: vehicle3d`` vehicle file): vertical profile, cross
level and alignment under wheelsets 1..4, then their rates
(:data:`modal_twin.models.vehicle3d_factory.INPUT_NAMES_3D`)."""


@dataclass(frozen=True, slots=True)
class ExcitationConfig:
    """Parameters of the excitation node (ROS parameters of the same names)."""

    kind: str = field(default="random", metadata={"doc": f"one of {KINDS}"})
    channels: tuple[str, ...] = field(
        default=("ax", "ay", "az", "arx", "ary", "arz"),
        metadata={"doc": "drive channels (table DOF: m/s^2 and rad/s^2)"},
    )
    fs_hz: float = field(default=1000.0, metadata={"doc": "drive sample rate"})
    duration_s: float = field(default=20.0, metadata={"doc": "length of the drive"})
    block_size: int = field(default=50, metadata={"doc": "samples per published block"})
    rms: tuple[float, ...] = field(
        default=(0.2, 0.2, 0.05, 0.0, 0.0, 0.0),
        metadata={"doc": "RMS per channel (random, multisine) or peak (chirp, earthquake)"},
    )
    f_min_hz: float = field(default=0.2, metadata={"doc": "band lower edge"})
    f_max_hz: float = field(default=30.0, metadata={"doc": "band upper edge"})
    record_path: str = field(default="", metadata={"doc": ".npz or .csv record (kind=record)"})
    record_scale: float = field(default=1.0, metadata={"doc": "scale on the record"})
    seed: int = field(default=1, metadata={"doc": "random seed"})
    speed_kmh: float = field(default=300.0, metadata={"doc": "running speed (kind=track)"})
    vehicle_file: str = field(default="config/vehicles/trailer_car.yaml",
                              metadata={"doc": "vehicle whose axle positions the track "
                                        "irregularity passes under (kind=track); a 3D car "
                                        "(kind: vehicle3d) takes the 3D track channels"})
    track_level: str = field(default="low", metadata={
        "doc": "German track spectrum, low or high interference (kind=track, 3D car)"})
    impact_spacing_s: float = field(default=4.0, metadata={
        "doc": "time between hammer hits (kind=impact)"})
    hits_per_point: int = field(default=5, metadata={
        "doc": "hits on each drive channel before the hammer roves to the next (kind=impact)"})
    tip_stiffness_n_m: float = field(default=1e5, metadata={
        "doc": "contact stiffness of the hammer tip: the pulse lasts pi sqrt(m / k)"})
    hammer_mass_kg: float = field(default=0.3, metadata={"doc": "hammer head mass"})
    double_hit_every: int = field(default=0, metadata={
        "doc": "every n-th hit bounces (a second pulse of half the peak; 0 = never)"})
    overload_n: float = field(default=0.0, metadata={
        "doc": "force range the hammer clips at (0 = no clipping)"})
    overload_every: int = field(default=0, metadata={
        "doc": "every n-th hit is struck at twice its peak, clipped at overload_n (0 = never)"})
    autostart: bool = field(default=True, metadata={"doc": "start once a reader is matched"})
    rate: float = field(default=1.0, metadata={"doc": "pace: 1 = real time, 0 = flat out"})
    wait_subscribers: int = field(default=1, metadata={"doc": "readers to wait for"})

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            msg = f"kind: expected one of {KINDS}, got {self.kind!r}"
            raise OptionError(msg)
        if self.block_size < 1:
            msg = f"block_size: expected >= 1, got {self.block_size}"
            raise OptionError(msg)
        if self.kind == "track" and tuple(self.channels) not in (TRACK_CHANNELS,
                                                                 TRACK_CHANNELS_3D):
            msg = (f"channels: kind=track drives the track irregularity under the four "
                   f"wheelsets and its rate, expected {list(TRACK_CHANNELS)} (a vertical car) "
                   f"or {list(TRACK_CHANNELS_3D[:3])} ... ({len(TRACK_CHANNELS_3D)}, a 3D "
                   f"car), got {list(self.channels)}")
            raise OptionError(msg)
        if self.kind == "track" and not self.speed_kmh > 0:
            msg = f"speed_kmh: expected > 0, got {self.speed_kmh}"
            raise OptionError(msg)
        if self.kind == "impact" and not (self.impact_spacing_s > 0 and self.hits_per_point >= 1
                                          and self.tip_stiffness_n_m > 0
                                          and self.hammer_mass_kg > 0
                                          and self.double_hit_every >= 0
                                          and self.overload_n >= 0
                                          and self.overload_every >= 0):
            msg = ("impact: expected impact_spacing_s, tip_stiffness_n_m, hammer_mass_kg > 0, "
                   "hits_per_point >= 1, double_hit_every >= 0, overload_n >= 0, "
                   "overload_every >= 0")
            raise OptionError(msg)
        if self.kind == "impact" and self.overload_every and not self.overload_n > 0:
            msg = (f"overload_every: {self.overload_every} needs the range the hammer clips "
                   "at, overload_n > 0")
            raise OptionError(msg)
        if self.kind not in ("record", "track") and len(self.rms) not in (1, len(self.channels)):
            msg = (f"rms: expected 1 or {len(self.channels)} values (one per channel), "
                   f"got {len(self.rms)}")
            raise OptionError(msg)


def make_drive(cfg: ExcitationConfig) -> FloatArray:
    """Return the whole drive signal, shape (len(cfg.channels), n_samples)."""
    rng = np.random.default_rng(cfg.seed)
    n_ch = len(cfg.channels)
    if cfg.kind == "record":
        return _record_drive(cfg)
    if cfg.kind == "track":
        return _track_drive(cfg)
    rms = np.broadcast_to(np.asarray(cfg.rms, dtype=float), (n_ch,))
    if cfg.kind == "random":
        return signals.band_limited_random(
            n_ch, cfg.duration_s, cfg.fs_hz, f_min_hz=cfg.f_min_hz, f_max_hz=cfg.f_max_hz,
            rms=np.where(rms > 0, rms, 1.0), rng=rng,
        ) * (rms > 0)[:, None]
    if cfg.kind == "earthquake":  # independent synthetic components, peak = rms entry
        return np.vstack([
            signals.earthquake_like(cfg.duration_s, cfg.fs_hz, pga=1.0, rng=rng) * r
            for r in rms])
    if cfg.kind == "impact":
        return _impact_drive(cfg, rms)
    if cfg.kind in ("chirp", "multisine"):
        if cfg.kind == "chirp":
            one = signals.chirp(cfg.duration_s, cfg.fs_hz, f_min_hz=cfg.f_min_hz,
                                f_max_hz=cfg.f_max_hz)
        else:
            one = signals.multisine(cfg.duration_s, cfg.fs_hz, f_min_hz=cfg.f_min_hz,
                                    f_max_hz=cfg.f_max_hz, rng=rng)
        return rms[:, None] * one
    msg = f"kind: expected one of {KINDS}, got {cfg.kind!r}"
    raise OptionError(msg)


def _impact_drive(cfg: ExcitationConfig, peak: FloatArray) -> FloatArray:
    """Hammer hits every ``impact_spacing_s``, roving over the drive channels.

    Hit ``i`` lands on channel ``(i // hits_per_point) % n_channels`` with that channel's
    ``rms`` entry as its peak force; every ``double_hit_every``-th hit bounces (a second
    pulse of half the peak three contact times later), every ``overload_every``-th hit is
    struck twice as hard and ``overload_n`` clips the force (the acquisition's impact
    checks must reject both).
    """
    n_ch = len(cfg.channels)
    n = max(1, round(cfg.duration_s * cfg.fs_hz))
    out = np.zeros((n_ch, n))
    tc = np.pi * np.sqrt(cfg.hammer_mass_kg / cfg.tip_stiffness_n_m)
    n_hits = int((cfg.duration_s - 0.5) // cfg.impact_spacing_s) + 1
    for i in range(max(0, n_hits)):
        ch = (i // cfg.hits_per_point) % n_ch
        at = 0.5 + i * cfg.impact_spacing_s
        kw = {"tip_stiffness_n_m": cfg.tip_stiffness_n_m, "hammer_mass_kg": cfg.hammer_mass_kg}
        hard = 2.0 if cfg.overload_every and (i + 1) % cfg.overload_every == 0 else 1.0
        out[ch] += signals.hammer_pulse(n, cfg.fs_hz, peak_n=hard * float(peak[ch]), at_s=at,
                                        **kw)
        if cfg.double_hit_every and (i + 1) % cfg.double_hit_every == 0:
            out[ch] += signals.hammer_pulse(n, cfg.fs_hz, peak_n=0.5 * float(peak[ch]),
                                    at_s=at + 3 * tc, **kw)
    if cfg.overload_n > 0:
        out = np.clip(out, -cfg.overload_n, cfg.overload_n)
    return out


def _track_drive(cfg: ExcitationConfig) -> FloatArray:
    """Return the vertical irregularity of a random German low-interference track and its rate.

    Both are taken under the wheelsets of ``cfg.vehicle_file`` running at ``cfg.speed_kmh``.
    A 3D car's file (``kind: vehicle3d``) gets :func:`_track_drive_3d`.

    Raises
    ------
    OptionError
        Channels of the other kind of car than the file's.
    """
    from modal_twin.models.track import random_profile, wheelset_inputs
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file
    from modal_twin.models.vehicle_spec import load_vehicle
    from modal_twin.paths import resolve_config

    path = resolve_config(cfg.vehicle_file)
    is_3d = is_vehicle3d_file(path)
    if is_3d != (tuple(cfg.channels) == TRACK_CHANNELS_3D):
        msg = (f"channels: {cfg.vehicle_file} is a {'3D' if is_3d else 'vertical-plane'} car, "
               f"its track channels are "
               f"{list((TRACK_CHANNELS_3D if is_3d else TRACK_CHANNELS)[:4])} ...")
        raise OptionError(msg)
    if is_3d:
        return _track_drive_3d(cfg, path)
    spec = load_vehicle(path)
    v = cfg.speed_kmh / 3.6
    prof = random_profile(v * cfg.duration_s + spec.length + 20.0, rng=cfg.seed)
    return wheelset_inputs(prof, spec.axle_x, v, cfg.fs_hz, cfg.duration_s)


def _track_drive_3d(cfg: ExcitationConfig, path: Path) -> FloatArray:
    """Return the 3D car's track: profile, cross level and alignment of a German spectrum.

    Drawn by :func:`modal_twin.models.track3d.random_track_3d` (``cfg.track_level``) and
    taken under the car's wheelsets (:func:`~modal_twin.models.track3d.track_inputs_3d`);
    the car's wheel-rail contact is built at its file's speed, which ``cfg.speed_kmh``
    must equal.

    Raises
    ------
    OptionError
        A speed other than the file's, or an unknown track level.
    """
    from modal_twin.models.track3d import random_track_3d, track_inputs_3d
    from modal_twin.models.vehicle3d_spec import load_vehicle3d

    spec = load_vehicle3d(path)
    if not np.isclose(cfg.speed_kmh, spec.speed_kmh):
        msg = (f"speed_kmh: the 3D car's contact is built at its file's speed_kmh "
               f"{spec.speed_kmh:g}, got {cfg.speed_kmh:g}")
        raise OptionError(msg)
    v = spec.speed
    track = random_track_3d(v * cfg.duration_s + spec.v("carbody", "length") + 20.0,
                            level=cfg.track_level, rng=cfg.seed)
    return track_inputs_3d(track, spec.axle_x, v, cfg.fs_hz, cfg.duration_s)


def _record_drive(cfg: ExcitationConfig) -> FloatArray:
    n_ch = len(cfg.channels)
    data, fs_rec, names = signals.load_record(cfg.record_path)
    if data.shape[0] != n_ch:
        msg = (f"record {cfg.record_path}: expected {n_ch} channels {list(cfg.channels)}, "
               f"got {data.shape[0]} {names}")
        raise OptionError(msg)
    if fs_rec != cfg.fs_hz:
        data = signals.resample_record(data, fs_rec, cfg.fs_hz)
    return cfg.record_scale * data
