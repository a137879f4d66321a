"""Photometric units from the light tracer's RGB flux.

The tracer carries flux per linear RGB channel in W. sonolux reads those watts as
*radiant-equivalent* watts at a stated luminous efficacy: a channel's flux Φ_c gives the luminous
flux Φ_v = K · Σ_c Y_c Φ_c, where Y = (0.2126, 0.7152, 0.0722) are the photopic luminance
weights of linear Rec. 709 / sRGB primaries (ITU-R BT.709-6, item 3.3; derived from the CIE 1931
colour-matching function ȳ = V(λ) at the Rec. 709 primaries and D65 white) and K defaults to
K_m = 683 lm/W, the maximum luminous efficacy of photopic vision (CIE 1931; the SI definition of
the candela, 540 THz). So a white light of 1 W in every channel is 683 lm.

The same factor turns every radiometric quantity of the tracer into its photometric twin:
irradiance (W/m²) into illuminance (lx), radiance (W/m²/sr) into luminance (cd/m²), radiant
intensity (W/sr) into luminous intensity (cd). A light given in lumens gets the channel flux
Φ_c = Φ_v / K × colour_c / (Y · colour), which gives back Φ_v exactly.
"""

from __future__ import annotations

import numpy as np

#: Photopic luminance weights of linear Rec. 709 RGB (ITU-R BT.709-6).
LUMINANCE_RGB = np.array([0.2126, 0.7152, 0.0722])
#: Maximum luminous efficacy of photopic vision, lm/W (CIE; SI definition of the candela).
MAX_LUMINOUS_EFFICACY_LM_PER_W = 683.0


def photometric(rgb: np.ndarray, efficacy_lm_per_w: float = MAX_LUMINOUS_EFFICACY_LM_PER_W) -> np.ndarray:
    """K · Y · rgb over the last axis (size 3): lm from W, lx from W/m², cd/m² from W/m²/sr."""
    rgb = np.asarray(rgb, float)
    if rgb.shape[-1:] != (3,):
        raise ValueError(f"photometric: expected a last axis of 3 channels, got shape {rgb.shape}")
    return efficacy_lm_per_w * (rgb @ LUMINANCE_RGB)


def channel_flux_from_lumens(flux_lm: float, color_rgb: np.ndarray,
                             efficacy_lm_per_w: float = MAX_LUMINOUS_EFFICACY_LM_PER_W) -> np.ndarray:
    """float64[3]: the channel flux (W) of a light of ``flux_lm`` lumens and colour ``color_rgb``
    (zero for a black colour)."""
    color = np.asarray(color_rgb, float)
    y = float(color @ LUMINANCE_RGB)
    return flux_lm / efficacy_lm_per_w * color / y if y > 0 else np.zeros(3)


def channel_scale_per_candela(color_rgb: np.ndarray,
                              efficacy_lm_per_w: float = MAX_LUMINOUS_EFFICACY_LM_PER_W) -> np.ndarray:
    """float64[3]: W/sr per channel for 1 cd of a light of colour ``color_rgb``."""
    return channel_flux_from_lumens(1.0, color_rgb, efficacy_lm_per_w)
