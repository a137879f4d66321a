"""The bounds of the settings that the command line, the scene file and the API share, so that
a value allowed in one place is allowed in the others. Each is checked with
:func:`sonolux.errors.check_number` (or the scene's :class:`~sonolux.scene.schema.Table`)."""

from __future__ import annotations

#: Seeds are the core's u64.
MAX_SEED = 2**64 - 1
#: Worker threads of one run (the core's ``sonolux_core::sound::MAX_THREADS``; 0 = every core).
MAX_THREADS = 1024
#: The longest response a bake keeps, in seconds (longer than any room's decay).
MAX_TIME_S = 120.0
#: The largest ray or particle count (a bake of this many rays takes days).
MAX_RAYS = 10**12
#: Gains in dB a user may ask for (beyond ±120 dB nothing audible is left, or everything clips).
MAX_GAIN_DB = 120.0
#: Exposure in EV stops either way (2^±40 covers any physical scene).
MAX_EXPOSURE_EV = 40.0
#: The farthest a scene's geometry may reach from the origin, in metres (100 km: far beyond any
#: building, and the core's single-precision vertices still resolve 8 mm there; the vertex
#: weld's integer grid of 1 µm stays far inside int64).
MAX_COORDINATE_M = 1e5
