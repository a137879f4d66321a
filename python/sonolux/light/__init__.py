"""The light half of sonolux: baking the light on every surface patch with the particle tracer
that also traces sound, reading it back, and pictures of it (renders, glTF export).

Conventions (see docs/light.md): a light's ``power_w`` is the mean of its flux over the three
channels, so channel c carries ``power_w × color_rgb[c] / mean(color_rgb)`` watts; a
material's ``diffuse_rgb`` is its total reflectance, of which the share ``specular`` is
reflected as a mirror (roughness 0) or glossy lobe and the rest diffusely.
"""
