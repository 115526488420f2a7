"""Plants of a 3D vehicle file: the car of :mod:`modal_twin.models.vehicle3d` for the twin.

The 3D counterpart of :class:`~modal_twin.models.vehicle_factory.VehicleFactory`, with the
protocol :class:`~modal_twin.models.loading.ModelFactory` (``plant``, ``sites``,
``with_theta``, ``parameters``, ``parameter_info``).

Second-order form. The twin's simulator integrates ``M x'' + C x' + K x = -Gamma w -
sum B' f`` (Eq. (12) of [004]); the car's Maxwell dampers have a first-order state, the
dashpot's stroke ``e`` (``c e' = k (d - e)``, :mod:`modal_twin.models.vehicle3d`). Each
one gets the coordinate ``p`` with ``p' = e`` (the dashpot's stroke integrated), so that::

    c p'' + k p' - k g' q = k h' u          (the dashpot's own equation)
    ... + k g g' q - k g p' = -k g h' u      (the element's force k (d - e) on q)

exactly the first-order model (the coordinate ``p`` itself never acts: one zero
eigenvalue per damper, which carries the dashpot's free drift). ``x = [q; p]``, the
input ``w = [u; u']`` of :func:`modal_twin.models.track3d.track_inputs_3d` and the
contact at the file's speed: the plant's frequency response is the car's
(:meth:`~modal_twin.models.vehicle3d.Vehicle3D.state_space`) to rounding.

Device sites: every suspension element: the primary springs in x, y, z and the primary
vertical dashpots, the air springs in x, y, z, the vertical, lateral and yaw dampers, the
traction rods, the anti-roll bars, and every equipment hanger in x, y, z (spring-dampers
of the boxes on elastic hangers, :mod:`modal_twin.models.vehicle3d`). The stroke of a
primary vertical element holds the track's vertical profile and cross level (``h != 0``):
its device sees ``B x + E w`` and the rate ``B x' + Ed w`` with ``E = [h, 0]``, ``Ed = [0,
h]`` on ``w = [u; u']`` (the input share, :meth:`Vehicle3DFactory.site_inputs`, as the
vertical-plane car's primary suspensions). A device law placed at a site replaces the whole
element (its track terms leave ``Gamma``); the registry's ``linear`` law at a spring site
is the element itself (its :class:`~modal_twin.models.structure_yaml.DeviceSpec`
carries the element's ``k`` and ``c``); at a Maxwell site the spec carries the series
joint's ``k`` and the dashpot's ``c`` (the scale of the registry's relative laws), so a
``linear`` law there is the two in parallel, not the Maxwell element (the model itself
keeps the Maxwell element until a law replaces it). Parameters ``k_<element>`` and
``c_<element>`` (a Maxwell element's ``k`` is its series stiffness) change one element's
values.

Channels: the floor accelerations ``floor_<label>_z`` / ``_y`` (m/s^2, absolute), then of
each site its stroke ``<site>_d<axis>`` (role ``device_drift``) and force ``<site>_f<axis>``
(``device_force``: ``k d + c d'``, ``k (d - p')`` of a Maxwell element, or its device's);
a primary vertical element's stroke and force take the track's share through ``D_out``.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError
from modal_twin.models.carbody_interface import ReducedCarbody
from modal_twin.models.devices import Device
from modal_twin.models.effects import EffectSpec, effect_device
from modal_twin.models.loading import merge_effects, split_sensor_effects
from modal_twin.models.parameter_info import Kind, ParameterInfo
from modal_twin.models.plant import Plant, Source, with_sensor_effects
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.models.structure_yaml import DeviceSpec
from modal_twin.models.vehicle3d import (
    N_AXLES,
    N_U,
    SuspensionElement,
    carbody_full,
    default_carbody,
    mass_matrix,
    n_coordinates,
    suspension_elements,
)
from modal_twin.models.vehicle3d_spec import G_ACC, Vehicle3DSpec, load_vehicle3d
from modal_twin.models.wheel_rail import WheelRailContact, contact_matrices

__all__ = ["INPUT_NAMES_3D", "Vehicle3DFactory", "build_vehicle3d_plant"]

INPUT_NAMES_3D: tuple[str, ...] = tuple(
    [f"{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, N_AXLES + 1)]
    + [f"d{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, N_AXLES + 1)])
"""Track vertical profile (m), cross level (rad) and alignment (m) under wheelsets 1..4,
then their rates: the input ``[u; u']`` of :func:`modal_twin.models.track3d.
track_inputs_3d`."""

_BOUNDS: dict[str, tuple[Kind, str, float, float]] = {
    "k": ("stiffness", "N/m", 0.3, 3.0), "c": ("damping", "N s/m", 0.01, 5.0)}


def _is_site(el: SuspensionElement) -> bool:
    # a Maxwell damper switched off (c = 0) is no element of the car (vehicle3d)
    return el.c > 0.0 if el.kind == "maxwell" else (el.k > 0.0 or el.c > 0.0)


def _input_share(el: SuspensionElement) -> tuple[FloatArray, FloatArray]:
    """Return the track's share of an element's stroke and its rate, rows on ``[u; u']``."""
    zero = np.zeros(N_U)
    return np.concatenate([el.h, zero]), np.concatenate([zero, el.h])


def _units(el: SuspensionElement) -> tuple[str, str]:
    return ("rad", "N m") if el.name.startswith("anti_roll_bar") else ("m", "N")


@dataclass(frozen=True, slots=True)
class _Assembly:
    """The second-order system of the car (module docstring) before devices."""

    M: FloatArray
    C: FloatArray
    K: FloatArray
    Gamma: FloatArray
    n_q: int
    maxwell: dict[str, int]  # element -> its coordinate p


def _assemble(spec: Vehicle3DSpec, cb: ReducedCarbody, els: list[SuspensionElement],
              replaced: Iterable[str]) -> _Assembly:
    """M, C, K, Gamma of ``x = [q; p]`` with the elements of ``replaced`` left out."""
    skip = set(replaced)
    nq = n_coordinates(spec, cb)
    mx = [el for el in els if el.kind == "maxwell" and el.c > 0.0 and el.name not in skip]
    n = nq + len(mx)
    M, C, K = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    M[:nq, :nq] = mass_matrix(spec, cb)
    K[:nq, :nq], C[:nq, :nq] = carbody_full(cb, nq)
    Gamma = np.zeros((n, 2 * N_U))
    for el in els:
        if el.name in skip:
            continue
        if el.kind in ("damper", "spring_damper"):
            C[:nq, :nq] += el.c * np.outer(el.g, el.g)
            Gamma[:nq, N_U:] += el.c * np.outer(el.g, el.h)
        if el.kind in ("spring", "spring_damper") or (el.kind == "maxwell" and el.c > 0.0):
            K[:nq, :nq] += el.k * np.outer(el.g, el.g)
            Gamma[:nq, :N_U] += el.k * np.outer(el.g, el.h)
    index = {}
    for j, el in enumerate(mx):
        ip = nq + j
        index[el.name] = ip
        M[ip, ip], C[ip, ip] = el.c, el.k
        C[:nq, ip] = -el.k * el.g
        K[ip, :nq] = -el.k * el.g
        Gamma[ip, :N_U] = -el.k * el.h
    contact = WheelRailContact(spec.v("contact", "conicity"), spec.v("contact", "r0"),
                               spec.v("contact", "b"), spec.v("contact", "f11"),
                               spec.v("contact", "f22"), axle_load=spec.axle_load)
    Cc, Kc, Ba = contact_matrices(contact, spec.speed)
    for a in range(N_AXLES):
        iy = cb.n + 12 + 2 * a
        ix = np.ix_([iy, iy + 1], [iy, iy + 1])
        K[ix] += Kc
        C[ix] += Cc
        Gamma[[iy, iy + 1], 2 * N_AXLES + a] -= Ba  # alignment under wheelset a
    return _Assembly(M, C, K, Gamma, nq, index)


def build_vehicle3d_plant(spec: Vehicle3DSpec, *, carbody: ReducedCarbody | None = None,
                          site_devices: Mapping[str, Device] | None = None,
                          device_channels: Iterable[str] = (),
                          theta: Mapping[str, float] | None = None) -> Plant:
    """Return the 3D car as a twin :class:`~modal_twin.models.plant.Plant` (module docstring).

    Parameters
    ----------
    spec : Vehicle3DSpec
        At its ``speed_kmh``.
    carbody : ReducedCarbody, optional
        Default :func:`~modal_twin.models.vehicle3d.default_carbody` of ``spec``.
    site_devices : mapping, optional
        Site -> a device law that replaces that element (its drift along the element).
    device_channels : iterable of str
        Sites whose stroke and force are channels after the floor accelerations.
    theta : mapping, optional
        Element values ``k_<element>`` / ``c_<element>`` (names not checked here:
        :class:`Vehicle3DFactory` checks them).

    Raises
    ------
    OptionError
        A device or a channel at a name that is not a site.
    """
    cb = default_carbody(spec) if carbody is None else carbody
    els = _with_values(suspension_elements(spec, cb), theta or {})
    sites = {el.name: el for el in els if _is_site(el)}
    given = dict(site_devices or {})
    chans = tuple(device_channels)
    unknown = sorted((set(given) | set(chans)) - set(sites))
    if unknown:
        msg = f"sites: expected names from {list(sites)}, got {unknown}"
        raise OptionError(msg)
    asm = _assemble(spec, cb, els, given)
    n, nq = asm.M.shape[0], asm.n_q
    atts = []
    for name, dev in given.items():
        B = np.zeros((dev.n_dir, n))
        B[0, :nq] = sites[name].g
        if not np.any(sites[name].h):
            atts.append(DeviceAttachment(device=dev, B=B))
            continue
        E, Ed = np.zeros((dev.n_dir, 2 * N_U)), np.zeros((dev.n_dir, 2 * N_U))
        E[0], Ed[0] = _input_share(sites[name])
        atts.append(DeviceAttachment(device=dev, B=B, E=E, Ed=Ed))
    rows, names, channels = [], [], []
    h = spec.v("carbody", "floor_height")
    for p in spec.floor_points:
        _, P = cb.points[p.label]
        for axis in ("z", "y"):
            row = np.zeros(n)
            row[: cb.n] = P["xyz".index(axis)]
            rows.append(np.concatenate([np.zeros(2 * n), row]))
            names.append(f"floor_{p.label}_{axis}")
            channels.append(ChannelSpec(names[-1], "acceleration", f"floor_{p.label}", axis,
                                        position_m=(p.x, p.y, h)))
    feed = [np.zeros(2 * N_U) for _ in rows]
    sources: list[Source] = [("y", i) for i in range(len(rows))]
    f_row = {}
    r = 0
    for name, att in zip(given, atts, strict=True):
        f_row[name] = r
        r += att.device.n_dir
    for qty, key, role in (("displacement", "d", "device_drift"),
                           ("force", "f", "device_force")):
        for site in chans:
            el = sites[site]
            g = np.zeros(n)
            g[:nq] = el.g
            unit = _units(el)[0 if key == "d" else 1]
            channels.append(ChannelSpec(f"{site}_{key}{el.axis}", qty, site, el.axis,
                                        role=role, unit_si=unit))
            if key == "f" and site in given:
                sources.append(("force", f_row[site]))
                continue
            eu, ev = _input_share(el)
            if key == "d":
                row = np.concatenate([g, np.zeros(2 * n)])
                fed = eu
            elif el.kind == "maxwell":
                row = np.concatenate([el.k * g, np.zeros(2 * n)])
                row[n + asm.maxwell[site]] = -el.k
                fed = el.k * eu
            else:
                row = np.concatenate([el.k * g, el.c * g, np.zeros(n)])
                fed = el.k * eu + el.c * ev
            sources.append(("y", len(rows)))
            rows.append(row)
            feed.append(fed)
            names.append(channels[-1].name)
    C_out = np.array(rows)
    system = ReducedSystem(M=asm.M, C=asm.C, K=asm.K, Gamma=asm.Gamma, devices=tuple(atts),
                           C_out=C_out, D_out=np.array(feed).reshape(C_out.shape[0], 2 * N_U),
                           output_names=tuple(names))
    label = ",".join(f"{k}:{type(d).__name__}" for k, d in given.items()) or "nominal"
    quantities = ("displacement",) * N_U + ("velocity",) * N_U
    return Plant(system, INPUT_NAMES_3D, quantities, tuple(channels), tuple(sources),
                 name=f"{spec.name}@{label}")


def _with_values(els: list[SuspensionElement], theta: Mapping[str, float]
                 ) -> list[SuspensionElement]:
    return [replace(el, k=float(theta.get(f"k_{el.name}", el.k)),
                    c=float(theta.get(f"c_{el.name}", el.c))) for el in els]


class Vehicle3DFactory:
    """Build plants of one 3D vehicle file with element values and device laws.

    Parameters
    ----------
    vehicle_file : path
        A ``kind: vehicle3d`` file.
    theta : mapping, optional
        Element values ``k_<element>`` / ``c_<element>`` (:meth:`parameters`).
    """

    base_effects: tuple[EffectSpec, ...] = ()
    label: str = ""
    parameter_prefixes = ("k_", "c_")

    def __init__(self, vehicle_file: str | Path, *,
                 theta: Mapping[str, float] | None = None) -> None:
        self.structure_file = Path(vehicle_file)
        self.spec = load_vehicle3d(vehicle_file)
        self._carbody = default_carbody(self.spec)  # the shell's reduction: built once
        self._nominal = {el.name: el for el in suspension_elements(self.spec, self._carbody)}
        self.theta: dict[str, float] = {}
        self._check(dict(theta or {}))
        self.theta = dict(theta or {})

    def _check(self, theta: Mapping[str, float]) -> None:
        names = self._names()
        for k, v in theta.items():
            if k not in names:
                msg = f"parameter: expected one of {names[:6]} ... ({len(names)}), got {k!r}"
                raise OptionError(msg)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0.0):
                msg = f"{k}: expected a finite value > 0, got {v!r}"
                raise OptionError(msg)

    def _names(self) -> list[str]:
        out = []
        for el in self._nominal.values():
            if el.k > 0.0:
                out.append(f"k_{el.name}")
            if el.c > 0.0:
                out.append(f"c_{el.name}")
        return out

    def elements(self) -> list[SuspensionElement]:
        """Return the car's elements with the parameter values applied."""
        return _with_values(list(self._nominal.values()), self.theta)

    @property
    def sites(self) -> dict[str, DeviceSpec]:
        """Device sites (module docstring) with their ``k`` and ``c`` now."""
        out = {}
        for j, el in enumerate(e for e in self.elements() if _is_site(e)):
            k = 0.0 if el.kind == "damper" else el.k
            c = 0.0 if el.kind == "spring" else el.c
            out[el.name] = DeviceSpec(el.name, j, np.array([k, k]), np.array([c, c]), 0.0,
                                      "linear")
        return out

    def with_theta(self, changes: Mapping[str, float]) -> Vehicle3DFactory:
        """Return the same car with some element values changed (the file is not read)."""
        self._check(changes)
        new = copy.copy(self)
        new.theta = {**self.theta, **changes}
        return new

    def parameters(self) -> dict[str, float]:
        """Return the current value of every parameter."""
        vals = {}
        for el in self.elements():
            if f"k_{el.name}" in self._names():
                vals[f"k_{el.name}"] = el.k
            if f"c_{el.name}" in self._names():
                vals[f"c_{el.name}"] = el.c
        return vals

    def parameter_info(self, name: str) -> ParameterInfo:
        """Kind, place (the element), nominal value (the file's) and bounds of a parameter.

        Raises
        ------
        OptionError
            Unknown name.
        """
        if name not in self._names():
            self._check({name: 1.0})
        key, _, element = name.partition("_")
        kind, unit, lo, hi = _BOUNDS[key]
        el = self._nominal[element]
        v = el.k if key == "k" else el.c
        if el.name.startswith("anti_roll_bar"):
            unit = "N m/rad"
        return ParameterInfo(name, kind, element.replace("_", " "), v, lo * v, hi * v, unit,
                             "device")

    def attachments(self) -> tuple[str, ...]:
        """No ``elastic_mount`` candidates: a box of the file is hung or part of the carbody."""
        return ()

    def site_inputs(self, component: str) -> tuple[dict[str, float], dict[str, float]]:
        """Return the track's share of a site's stroke and of its rate (input -> coefficient).

        A primary vertical element's stroke holds the vertical profile ``zt<a>`` and the
        cross level ``phit<a>`` under its wheelset (its rate their rates ``dzt<a>``,
        ``dphit<a>``); the other sites' strokes hold no input.

        Raises
        ------
        OptionError
            Not a site.
        """
        el = self._site_element(component)
        eu, ev = _input_share(el)
        return ({INPUT_NAMES_3D[i]: float(eu[i]) for i in np.flatnonzero(eu)},
                {INPUT_NAMES_3D[i]: float(ev[i]) for i in np.flatnonzero(ev)})

    def _site_element(self, component: str) -> SuspensionElement:
        els = {el.name: el for el in self.elements() if _is_site(el)}
        if component not in els:
            msg = f"site: expected one of {list(els)[:4]} ... ({len(els)}), got {component!r}"
            raise OptionError(msg)
        return els[component]

    def weight(self, component: str) -> float:
        """Return the static load on a vertical element, N, else 0.

        An air spring's vertical element carries a quarter of the carbody, a primary
        vertical spring an eighth of the carbody and a quarter of its bogie, an equipment
        hanger's vertical element a quarter of its box.
        """
        v = self.spec.v
        if not component.endswith("_z"):
            return 0.0
        if component.startswith("air_spring_"):
            return 0.25 * G_ACC * v("carbody", "mass")
        if component.startswith("primary_"):
            return G_ACC * (0.125 * v("carbody", "mass") + 0.25 * v("bogie", "mass"))
        for box in self.spec.hung_equipment:
            if component.startswith(f"{box.name}_hanger"):
                return 0.25 * G_ACC * box.mass
        return 0.0

    def plant(self, effects: Iterable[EffectSpec] = ()) -> Plant:
        """Return the plant with device laws at sites (and sensor effects) in place.

        Raises
        ------
        OptionError
            An effect that is neither a device law at a site nor a sensor effect.
        """
        effects, sensors = split_sensor_effects(merge_effects(self.base_effects, effects))
        sites = self.sites
        devices = {}
        for e in effects:
            if e.component not in sites:
                msg = (f"effect {e.law!r} at {e.component!r}: the 3D car takes device laws at "
                       f"{list(sites)[:4]} ... ({len(sites)} sites) and parameter changes")
                raise OptionError(msg)
            devices[e.component] = effect_device(sites[e.component], e.law, e.params,
                                                 weight=self.weight(e.component))
        plant = build_vehicle3d_plant(self.spec, carbody=self._carbody, site_devices=devices,
                                      device_channels=tuple(sites), theta=self.theta)
        plant = replace(plant, name=f"{plant.name}#{self.label}") if self.label else plant
        return with_sensor_effects(plant, sensors)
