"""``sonolux export FIELD --sofa OUT.sofa``: the field's synthesised responses as an AES69 (SOFA)
file of the ``SingleRoomSRIR`` convention, written with ``sofar``.

Why SingleRoomSRIR: it holds spatial room impulse responses of one room, measured by one array of
receivers (R) at several listener positions (M), from a source. That is what a sound field is:
at every receiver (a listener position), one response per direction sector of the receiver's
sphere, as if a directional microphone pointed along each sector's centre. MultiSpeakerBRIR
holds binaural responses (two ears) of several loudspeakers: it would need our directions
rendered to ears first, which throws away what a user of the file wants to do themselves.

What the file holds (SOFA's axes and units: metres; spherical positions as azimuth
counter-clockwise from +x seen from above, elevation up from the horizontal, radius; both as in
sonolux, so nothing is rotated):

- ``Data_IR[M, R, N]``: response (receiver m, direction r) is
  ``SoundField.impulse_response(m, r, seed=seed + m × directions + r)`` (the web bundle's
  seeds, so the viewer plays the same responses), zero-padded to the longest; pressures in
  sqrt(W/m²) (:mod:`sonolux.sound.synthesis`; × sqrt(ρ₀c) ≈ 20.3 for pascals in air).
- ``ListenerPosition[M, 3]``: the receivers (cartesian, m); ``ListenerView`` +x, ``ListenerUp`` +z.
- ``ReceiverPosition[R, 3, 1]``: the sectors' centres on the receiver's sphere (spherical:
  azimuth, elevation in degrees, the sphere's radius in m); ``ReceiverView[R, 3, 1]`` the unit
  vector along each centre; ``ReceiverDescriptions[R]`` the sectors' names.
- ``SourcePosition[M, 3]``: the first source (cartesian, m); ``EmitterPosition[E, 3, 1]`` every
  source relative to it (a field with several sources holds their sum).
- ``RoomVolume`` from the bake's theory; ``GLOBAL_RoomType`` "reverberant".

The file is written beside its target and renamed into place, with the umask's permissions
(:mod:`sonolux.outputs`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_SEED

CONVENTION = "SingleRoomSRIR"


@dataclass
class SofaSummary:
    path: Path
    receivers: int
    directions: int
    samples: int
    sample_rate_hz: int

    def describe(self) -> str:
        return (f"SOFA {CONVENTION} {self.path}: {self.receivers} receiver(s) × {self.directions} "
                f"directions × {self.samples:,} samples ({self.samples / self.sample_rate_hz:.2f} s "
                f"at {self.sample_rate_hz} Hz)")


def direction_centres_deg(azimuth_bands: int, elevation_bands: int) -> np.ndarray:
    """float[direction, 2]: azimuth and elevation (degrees) of every direction sector's centre,
    in index order (elevation bands of equal solid angle: band e of n spans sin(el) in
    [−1 + 2e/n, −1 + 2(e+1)/n], centred on the middle of that)."""
    out = []
    for e in range(elevation_bands):
        el = 0.0 if elevation_bands == 1 else math.degrees(math.asin(-1 + (2 * e + 1) / elevation_bands))
        out += [(360.0 * a / azimuth_bands, el) for a in range(azimuth_bands)]
    return np.array(out, dtype=np.float64)


def export_sofa(field_path: str | Path, out_path: str | Path, receiver: int | None = None,
                seed: int = 0, log: Callable[[str], None] | None = None,
                sources: Sequence[Any] = ()) -> SofaSummary:
    """Writes the responses of one receiver (``receiver``) or of all (None) of the field file
    ``field_path`` to ``out_path`` (a .sofa file). Raises :class:`SonoluxError` for a path,
    receiver or seed that is not allowed, before anything is synthesised. ``sources``: which
    of the field's sources (:func:`sonolux.sound.pick.pick_sources`; default all, summed)."""
    import sofar

    from sonolux.fieldfile import open_field
    from sonolux.memory import check_memory
    from sonolux.outputs import atomic_output
    from sonolux.version import __version__

    say = log or (lambda _m: None)
    out_path = Path(out_path)
    if out_path.suffix.lower() != ".sofa":
        raise SonoluxError(f"{out_path}: a SOFA file must end in .sofa")
    seed = check_number("seed", seed, 0, MAX_SEED, integer=True)
    from sonolux.sound.pick import pick_sources

    field = pick_sources(open_field(field_path), sources)
    if field.n_receivers == 0:
        raise SonoluxError(f"{field_path}: the field has no receivers, so no responses to export")
    chosen = list(range(field.n_receivers)) if receiver is None else [field.receiver_index(receiver)]
    n_dir = int(field.energy.shape[1])
    fs = field.sample_rate_hz
    # The responses are at most the field's time axis long (pressure_ir): synthesised straight
    # into one float64 array of that length (then cut to the longest), which netCDF may copy
    # once more as it writes.
    n_axis = int(math.ceil(float(np.max(field.bin_start_s + field.bin_width_s)) * fs))
    check_memory(2.0 * 8 * len(chosen) * n_dir * n_axis, "the SOFA export",
                 f"{len(chosen)} receivers × {n_dir} directions × {n_axis:,} samples",
                 fits="export one receiver at a time with --receiver N")

    data = np.zeros((len(chosen), n_dir, n_axis))
    n = 0
    for k, m in enumerate(chosen):
        for d in range(n_dir):
            x = field.impulse_response(m, d, seed=seed + m * n_dir + d)
            data[k, d, :x.size] = x
            n = max(n, x.size)
        if len(chosen) > 1 and (k + 1) * 10 // len(chosen) > k * 10 // len(chosen):
            say(f"responses: {k + 1}/{len(chosen)} receivers")
    data = data[:, :, :n]

    sofa = sofar.Sofa(CONVENTION)
    sofa.GLOBAL_Title = f"{field.scene_name or 'sonolux'}: spatial room impulse responses"
    sofa.GLOBAL_RoomType = "reverberant"
    sofa.GLOBAL_RoomShortName = field.scene_name
    sofa.GLOBAL_RoomDescription = f"baked by sonolux from {field.scene_origin or 'a scene'}"
    sofa.GLOBAL_ApplicationName = "sonolux"
    sofa.GLOBAL_ApplicationVersion = __version__
    sofa.GLOBAL_Origin = f"sonolux export {Path(field_path).name} --sofa (seed {seed})"
    sofa.GLOBAL_ListenerShortName = "receiver sphere"
    sofa.GLOBAL_ListenerDescription = (f"sonolux receivers: spheres of radius {field.radius_m:g} m "
                                       "at the listener positions")
    sofa.GLOBAL_ReceiverShortName = "direction sectors"
    sofa.GLOBAL_ReceiverDescription = (
        f"{n_dir} direction sectors of the receiver's sphere ({field.azimuth_bands} azimuth × "
        f"{field.elevation_bands} elevation bands of equal solid angle): each receiver is the "
        "sound arriving from its sector, placed at the sector's centre and looking outward")
    sofa.GLOBAL_SourceDescription = "the scene's sound source(s), omnidirectional unless the scene says"
    sofa.GLOBAL_EmitterDescription = ("the field's sources, relative to the first; several "
                                      "sound together (their responses are summed)")
    sofa.GLOBAL_Comment = (
        "Data.IR is the sound pressure divided by sqrt(rho0 c), in sqrt(W/m^2): the sum of its "
        "squares over a time, divided by the sample rate, is the energy per area in J/m^2 "
        "(multiply by about 20.3 for pascals in air at 20 C). Synthesised from the field's "
        "energy histograms (Poisson impulses weighted per band); response (m, r) uses seed "
        f"{seed} + m * {n_dir} + r with m the receiver's index in the field.")
    sofa.Data_IR = data
    sofa.Data_SamplingRate = float(fs)
    sofa.Data_Delay = np.zeros((1, n_dir))
    # When the field was "measured": its file's time (seconds since 1970, as SOFA wants).
    sofa.MeasurementDate = np.full(len(chosen), float(int(Path(field_path).stat().st_mtime)))
    sofa.ListenerPosition = np.asarray(field.positions_m[chosen], dtype=np.float64)
    sofa.ListenerView = np.array([[1.0, 0.0, 0.0]])
    sofa.ListenerUp = np.array([[0.0, 0.0, 1.0]])
    centres = direction_centres_deg(field.azimuth_bands, field.elevation_bands)
    sofa.ReceiverPosition = np.column_stack([centres, np.full(n_dir, field.radius_m)])[:, :, None]
    sofa.ReceiverPosition_Type = "spherical"
    sofa.ReceiverPosition_Units = "degree, degree, metre"
    az, el = np.radians(centres[:, 0]), np.radians(centres[:, 1])
    sofa.ReceiverView = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                         np.sin(el)])[:, :, None]
    sofa.ReceiverUp = np.tile(np.array([0.0, 0.0, 1.0])[:, None], (n_dir, 1, 1))
    sofa.ReceiverDescriptions = np.array(field.direction_names)[:, None]
    sources = np.atleast_2d(np.asarray(field.source_positions_m, dtype=np.float64))
    sofa.SourcePosition = np.tile(sources[:1], (len(chosen), 1))  # the convention wants [M, C]
    sofa.EmitterPosition = (sources - sources[0])[:, :, None]
    sofa.EmitterPosition_Type = "cartesian"
    sofa.EmitterPosition_Units = "metre"
    sofa.EmitterView = np.tile(np.array([1.0, 0.0, 0.0])[:, None], (len(sources), 1, 1))
    sofa.EmitterUp = np.tile(np.array([0.0, 0.0, 1.0])[:, None], (len(sources), 1, 1))
    sofa.EmitterDescriptions = np.array([f"source {k}" for k in range(len(sources))])[:, None]
    volume = (field.theory or {}).get("volume_m3", field.settings.get("volume_m3"))
    if volume:
        sofa.RoomVolume = float(volume)
    sofa.verify(issue_handling="raise")

    with atomic_output(out_path) as tmp:
        sofar.write_sofa(str(tmp), sofa, compression=4)
    return SofaSummary(out_path, len(chosen), n_dir, n, fs)
