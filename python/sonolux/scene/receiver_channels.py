"""Directional receiver channels: the ``channels`` of a ``[receivers]`` table of points.

Every listed point gets one receiver sphere per channel, all at that point; each channel
weighs the sound it records by its pattern's energy gain towards the direction the sound
arrives from (``crates/sonolux-core/src/sound/receivers.rs``):

- ``"omni"`` (the default, alone): gain 1.
- The first-order microphones, pressure sensitivity a + (1 − a) cos θ, θ from the channel's
  ``forward`` (Eargle, *The Microphone Book*, 2nd ed., 2004, ch. 5): ``"cardioid"`` (a = 1/2),
  ``"supercardioid"`` ((√3 − 1)/2), ``"hypercardioid"`` (1/4), ``"figure-of-eight"`` (0);
  energy gain (a + (1 − a) cos θ)², 1 on the axis, as ISO 3382-1 A.2.4 calibrates a
  figure-of-eight against the omni. A figure-of-eight channel brings a companion channel
  ``"<name>|cos|"`` of gain |cos θ|: the product |p_L · p| that JLFC integrates.
- ``{ sofa = "array.sofa" }``: a measured microphone array, one channel per SOFA receiver
  (capsule), named ``"<name>:<k>"``. The file lists the directions sound came from as
  ``SourcePosition`` (spherical: azimuth counter-clockwise from x, elevation; or cartesian) in
  the array's frame (``ListenerView``/``ListenerUp``, x forward and z up by default), with the
  capsules' responses as ``Data.Real/Imag`` over ``N`` Hz (conventions ``GeneralTF``,
  ``SimpleFreeFieldHRTF``, ``FreeFieldHRTF``) or ``Data.IR`` at ``Data.SamplingRate``
  (``GeneralFIR``, ``SimpleFreeFieldHRIR``, ``FreeFieldHRIR``). Per band, a capsule's gain in
  each measured direction is the mean of |H(f)|² over the band's IEC 61260-1 edges (|H|²
  linear between the file's frequencies); on the sphere it is interpolated linearly on the
  triangulated directions, as a source's SOFA directivity (:mod:`sonolux.scene.sofa_directivity`).
  Unlike a source's pattern, its level is kept: |H| = 1 everywhere is an ideal omni.

A channel given as a table takes ``pattern`` (or ``sofa``), ``name``, ``forward`` (default +x;
``"lateral"``: horizontal and perpendicular to the line to the first source, the null of a
figure-of-eight towards it, as ISO 3382-1 A.2.4 places it) and ``up`` (default +z).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.scene.schema import Table, check_vector

#: Pressure a + (1 − a) cos θ of the first-order patterns.
FIRST_ORDER = {"omni": 1.0, "cardioid": 0.5, "supercardioid": (math.sqrt(3.0) - 1.0) / 2.0,
               "hypercardioid": 0.25, "figure-of-eight": 0.0}
#: The companion of a figure-of-eight channel: energy gain |cos θ| (JLFC).
LATERAL_PRODUCT = "figure-of-eight|cos|"
CHANNEL_KEYS = ("pattern", "sofa", "name", "forward", "up")
SOFA_TF = ("GeneralTF", "SimpleFreeFieldHRTF", "FreeFieldHRTF")
SOFA_IR = ("GeneralFIR", "SimpleFreeFieldHRIR", "FreeFieldHRIR")


@dataclass(frozen=True, eq=False)
class ReceiverChannel:
    """One channel: ``pattern`` a key of FIRST_ORDER, LATERAL_PRODUCT or "sofa"; ``forward``
    float64[3] or "lateral"; ``up`` float64[3]; a SOFA channel's ``sofa`` is the capsule's
    measured (directions float64[m, 3] in the array frame, frequencies_hz, power [m, f])."""

    name: str
    pattern: str
    forward: Any
    up: np.ndarray
    sofa: Any = None

    def describe(self) -> dict[str, Any]:
        """What the field file records of the channel (settings JSON)."""
        forward = self.forward if isinstance(self.forward, str) else np.asarray(self.forward).tolist()
        return {"name": self.name, "pattern": self.pattern, "forward": forward,
                "up": np.asarray(self.up).tolist(),
                "sofa": None if self.sofa is None else str(self.sofa.path)}


def read_channels(t: Table) -> tuple[ReceiverChannel, ...]:
    """The ``channels`` of a ``[receivers]`` table, expanded (companions, SOFA capsules)."""
    raw = t.data.get("channels", ["omni"])
    key = t.path("channels")
    if not isinstance(raw, list) or not raw:
        raise t.ctx.error(key, raw, "a non-empty list of patterns (" + ", ".join(FIRST_ORDER)
                          + ") or tables { pattern = …, forward = […] } / { sofa = \"file\" }")
    out: list[ReceiverChannel] = []
    for i, item in enumerate(raw):
        where = f"{key}[{i}]"
        if isinstance(item, str):
            item = {"pattern": item}
        if not isinstance(item, dict):
            raise t.ctx.error(where, item, "a pattern name or a table")
        unknown = sorted(set(item) - set(CHANNEL_KEYS))
        if unknown:
            raise t.ctx.error(f"{where}.{unknown[0]}", item[unknown[0]],
                              "one of the keys " + ", ".join(CHANNEL_KEYS))
        forward = item.get("forward", [1.0, 0.0, 0.0])
        if forward != "lateral":
            forward = _unit(t, f"{where}.forward", forward)
        up = _unit(t, f"{where}.up", item.get("up", [0.0, 0.0, 1.0]))
        # Only a measured (SOFA) pattern turns about its axis: there up must not be parallel.
        if ("sofa" in item and not isinstance(forward, str)
                and abs(float(forward @ up)) > 1.0 - 1e-6):
            raise t.ctx.error(f"{where}.up", up.tolist(), "a direction not parallel to forward")
        if "sofa" in item:
            if "pattern" in item:
                raise t.ctx.error(f"{where}.pattern", item["pattern"], "either pattern or sofa")
            name = _name(t, where, item, Path(str(item["sofa"])).stem)
            file = item["sofa"]
            if not isinstance(file, str):
                raise t.ctx.error(f"{where}.sofa", file, "a SOFA file name")
            path = Path(file) if Path(file).is_absolute() else t.ctx.base_dir / file
            try:
                capsules = read_sofa_receivers(path)
            except SonoluxError as exc:
                raise t.ctx.error(f"{where}.sofa", file, message=str(exc)) from None
            out += [ReceiverChannel(f"{name}:{k}", "sofa", forward, up, c)
                    for k, c in enumerate(capsules)]
            continue
        pattern = item.get("pattern", "omni")
        if not isinstance(pattern, str) or pattern not in FIRST_ORDER:
            raise t.ctx.error(f"{where}.pattern", pattern, ", ".join(FIRST_ORDER) + " (or sofa)")
        name = _name(t, where, item, pattern)
        out.append(ReceiverChannel(name, pattern, forward, up))
        if pattern == "figure-of-eight":
            out.append(ReceiverChannel(f"{name}|cos|", LATERAL_PRODUCT, forward, up))
    names = [c.name for c in out]
    if len(set(names)) != len(names):
        raise t.ctx.error(key, names, "channels with distinct names (give each a name)")
    return tuple(out)


def _name(t: Table, where: str, item: dict, default: str) -> str:
    name = item.get("name", default)
    if not isinstance(name, str) or not name:
        raise t.ctx.error(f"{where}.name", name, "a non-empty text")
    return name


def _unit(t: Table, key: str, value: Any) -> np.ndarray:
    v = check_vector(t.ctx, key, value, 3, "a list of 3 numbers (a direction)")
    n = float(np.linalg.norm(v))
    if not (n > 0 and math.isfinite(n)):
        raise t.ctx.error(key, value, "a non-zero finite direction")
    return v / n


def read_sofa_receivers(path: Path) -> list[Any]:
    """The capsules of a SOFA microphone array: one :class:`SofaDirectivity` each (directions
    in the array's frame x forward, y left, z up; power |H|² [direction, frequency])."""
    from sonolux.scene.sofa_directivity import SofaDirectivity, open_sofa, sphere_interpolate

    def bad(problem: str) -> SonoluxError:
        return SonoluxError(f"{path}: {problem}")

    sofa, convention = open_sofa(path)
    try:
        if convention in SOFA_TF:
            h = np.asarray(sofa.Data_Real, float) + 1j * np.asarray(sofa.Data_Imag, float)
            freqs = np.asarray(sofa.N, float).ravel()
        elif convention in SOFA_IR:
            ir = np.asarray(sofa.Data_IR, float)
            rate = float(np.asarray(sofa.Data_SamplingRate).ravel()[0])
            h = np.fft.rfft(ir, axis=-1)
            freqs = np.fft.rfftfreq(ir.shape[-1], 1.0 / rate)
        else:
            raise bad(f"SOFA convention {convention!r}; allowed for a receiver: "
                      + ", ".join(SOFA_TF + SOFA_IR))
        pos = np.asarray(sofa.SourcePosition, float)
        pos_type = str(getattr(sofa, "SourcePosition_Type", "spherical"))
        view = np.asarray(getattr(sofa, "ListenerView", [1.0, 0.0, 0.0]), float).reshape(-1, 3)[0]
        up = np.asarray(getattr(sofa, "ListenerUp", [0.0, 0.0, 1.0]), float).reshape(-1, 3)[0]
    except (AttributeError, ValueError) as exc:
        raise bad(f"a receiver array needs its Data, N (or SamplingRate) and SourcePosition "
                  f"({exc})") from None
    if h.ndim != 3 or h.shape[0] < 4 or h.shape[2] != len(freqs):
        raise bad(f"Data of shape {h.shape}: [measurement ≥ 4 directions, receiver, "
                  f"{len(freqs)} frequencies] expected")
    if pos.shape != (h.shape[0], 3):
        pos = np.broadcast_to(pos.reshape(-1, 3)[:1], (h.shape[0], 3)) if pos.size == 3 else pos
        if pos.shape != (h.shape[0], 3):
            raise bad(f"SourcePosition of shape {pos.shape}: one direction per measurement "
                      f"({h.shape[0]}, 3) expected")
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(freqs)) and np.all(np.diff(freqs) > 0)):
        raise bad("data must be finite and the frequencies increasing")
    if pos_type.startswith("spherical"):
        az, el = np.radians(pos[:, 0]), np.radians(pos[:, 1])
        xyz = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    else:
        xyz = pos
    norm = np.linalg.norm(xyz, axis=1)
    if np.any(~(norm > 0)):
        raise bad("a SourcePosition is at the array's centre: it has no direction")
    xyz = xyz / norm[:, None]
    forward = view / np.linalg.norm(view)
    up = up - forward * (up @ forward)
    if not (np.linalg.norm(up) > 1e-9):
        raise bad(f"ListenerView {view.tolist()} and ListenerUp must not be parallel")
    up = up / np.linalg.norm(up)
    local = np.stack([xyz @ forward, xyz @ np.cross(up, forward), xyz @ up], axis=1)
    try:
        sphere_interpolate(local, np.ones((len(local), 1)), local[:1])
    except SonoluxError as exc:
        raise bad(str(exc)) from None
    return [SofaDirectivity(path, local, freqs, np.abs(h[:, r, :]) ** 2)
            for r in range(h.shape[1])]


def sofa_receiver_gains(capsule: Any, edges_hz: np.ndarray) -> np.ndarray:
    """A capsule's mean |H|² per band on the engine's pattern grid: float64[theta, phi, band]."""
    from sonolux.scene.directivity import node_directions
    from sonolux.scene.sofa_directivity import band_energy, sphere_interpolate

    edges = np.asarray(edges_hz, float)
    mean = band_energy(capsule, edges) / (edges[:, 1] - edges[:, 0])
    grid = node_directions()
    flat = sphere_interpolate(capsule.directions, mean, grid.reshape(-1, 3))
    if np.any(flat.sum(axis=0) <= 0):
        raise SonoluxError(f"{capsule.path}: a capsule records nothing in some band")
    return flat.reshape(grid.shape[0], grid.shape[1], -1)


def lateral_axis(position_m: np.ndarray, source_m: np.ndarray) -> np.ndarray:
    """The horizontal unit axis perpendicular to the line from a receiver to the source (z ×
    the line's horizontal direction): float64[3]. Raises when the source is straight above."""
    d = np.asarray(source_m, float)[:2] - np.asarray(position_m, float)[:2]
    n = float(np.linalg.norm(d))
    if not n > 1e-9:
        raise SonoluxError(f"a lateral channel at {np.asarray(position_m).tolist()} has the "
                           "source straight above or below: no horizontal line to it")
    return np.array([-d[1] / n, d[0] / n, 0.0])
