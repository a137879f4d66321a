"""Geometry.closest_hit through the binding: the rays the arrays describe, whatever their
memory layout, on any thread count; malformed arrays named in the error."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.engine import Geometry
from sonolux.errors import InvalidInputError


def box_arrays(size=(4.0, 3.0, 2.0)) -> tuple[np.ndarray, np.ndarray]:
    """A closed box [0, L] x [0, W] x [0, H]: vertices, and 12 triangles facing in."""
    c = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float) * size
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6)]
    return c, np.array([tri for a, b, cc, d in quads for tri in ((a, b, cc), (a, cc, d))])


def box() -> Geometry:
    return Geometry(*box_arrays())


def core_box(core):
    """The binding's own Geometry, to reach its thread count and array handling."""
    v, t = box_arrays()
    return core.Geometry(v, t.astype(np.uint32), np.zeros(len(t), dtype=np.uint32))


def test_distances_to_the_walls_of_a_box_are_exact():
    g = box()
    rng = np.random.default_rng(5)
    o = rng.random((5000, 3)) * [4.0, 3.0, 2.0]
    # Along ±x, ±y, ±z the distance to the wall is known exactly.
    axes = np.eye(3)[rng.integers(0, 3, len(o))] * rng.choice([-1.0, 1.0], (len(o), 1))
    t, tri = g.closest_hit(o, axes)
    size = np.array([4.0, 3.0, 2.0])
    o32 = o.astype(np.float32).astype(float)  # the core traces in float32
    expect = np.where(axes > 0, size - o32, o32)[axes != 0]
    np.testing.assert_allclose(t, expect, rtol=1e-6, atol=1e-6)
    assert (tri >= 0).all() and (tri < 12).all()
    # t_max cuts: beyond it, a miss.
    t2, tri2 = g.closest_hit(o, axes, t_max=1.0)
    assert np.array_equal(tri2 >= 0, t < 1.0)
    assert np.isinf(t2[tri2 < 0]).all()


def test_memory_layout_and_threads_change_nothing(core):
    g = core_box(core)
    rng = np.random.default_rng(6)
    o = np.ascontiguousarray(rng.random((3001, 3)) * [4.0, 3.0, 2.0])
    d = rng.standard_normal((3001, 3))
    ref = g.closest_hit(o, d, threads=1)
    # Fortran order, and a strided view of a larger array: read as the same rays.
    strided = np.zeros((3001, 6))
    strided[:, ::2] = o
    for oo, dd, threads in [(np.asfortranarray(o), d, 1), (strided[:, ::2], np.asfortranarray(d), 2),
                            (o, d, 2)]:
        t, tri = g.closest_hit(oo, dd, threads=threads)
        assert np.array_equal(t, ref[0]) and np.array_equal(tri, ref[1])
    # Empty input, empty output.
    t, tri = g.closest_hit(np.zeros((0, 3)), np.zeros((0, 3)))
    assert t.shape == tri.shape == (0,)


def test_malformed_arrays_are_named(core):
    g = core_box(core)
    with pytest.raises(InvalidInputError, match="origins_m: expected shape"):
        g.closest_hit(np.zeros((4, 2)), np.zeros((4, 3)))
    with pytest.raises(InvalidInputError, match="directions: expected shape"):
        g.closest_hit(np.zeros((4, 3)), np.zeros((4, 4)))
    with pytest.raises(InvalidInputError, match="4 origins but 5 directions"):
        g.closest_hit(np.zeros((4, 3)), np.zeros((5, 3)))


def test_both_bvh_encodings_give_the_same_hits_and_a_wrong_one_is_named():
    """`bvh_encoding` "full" and "compressed" build the same tree on other nodes: the same
    distance and triangle, to the bit (docs/bvh.md, "Compressed nodes"); "auto" keeps a small
    mesh at full precision; any other value is refused with the setting named."""
    v, t = box_arrays()
    rng = np.random.default_rng(9)
    o = rng.random((20_000, 3)) * [4.0, 3.0, 2.0]
    d = rng.normal(size=(20_000, 3))
    full, compressed = Geometry(v, t, bvh_encoding="full"), Geometry(v, t, bvh_encoding="compressed")
    assert (full.bvh_compressed, compressed.bvh_compressed, box().bvh_compressed) == (False, True, False)
    (t_f, tri_f), (t_c, tri_c) = full.closest_hit(o, d), compressed.closest_hit(o, d)
    np.testing.assert_array_equal(t_f, t_c)
    np.testing.assert_array_equal(tri_f, tri_c)
    with pytest.raises(InvalidInputError, match="bvh_encoding: got 'fastest'"):
        Geometry(v, t, bvh_encoding="fastest")
