"""The sound half of sonolux: baking a sound field, reading it back, and impulse responses."""
