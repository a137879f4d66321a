"""Analysis of traced results: room-acoustic parameters from energy histograms (``decay``).

Functions here take plain numpy arrays, compute along the last (time) axis, and never need the
compiled core.
"""
