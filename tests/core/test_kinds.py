"""The table of kinds says what each kind promises; the promises hold."""

import numpy as np
import pytest

import gencoords
from gencoords.cages.shapes import icosphere


def test_the_table_is_the_list_of_kinds():
    assert gencoords.advanced.KINDS == tuple(kind.name for kind in gencoords.KIND_TABLE)
    assert gencoords.advanced.CONVEX_ONLY_KINDS == tuple(k.name for k in gencoords.KIND_TABLE if k.convex_only)
    assert len({kind.label for kind in gencoords.KIND_TABLE}) == len(gencoords.KIND_TABLE)


@pytest.mark.parametrize("kind", [k for k in gencoords.KIND_TABLE if not k.may_be_negative],
                         ids=lambda kind: kind.name)
def test_kinds_that_promise_positivity_stay_positive_inside(kind):
    vertices, faces = icosphere(1)
    points = np.random.default_rng(3).uniform(-0.5, 0.5, (400, 3))
    assert gencoords.coordinates(points, vertices, faces, kind=kind.name).min() > 0.0


@pytest.mark.parametrize("kind", gencoords.KIND_TABLE, ids=lambda kind: kind.name)
def test_convex_only_kinds_refuse_a_non_convex_cage_and_the_others_bind_it(kind):
    vertices, faces = icosphere(1)
    dented = vertices.copy()
    dented[0] *= 0.5  # pushed in: the cage is no longer convex
    point = np.array([[0.0, 0.0, -0.2]])
    if kind.convex_only:
        with pytest.raises(gencoords.CageError, match="not convex"):
            gencoords.coordinates(point, dented, faces, kind=kind.name)
    else:
        np.testing.assert_allclose(gencoords.coordinates(point, dented, faces, kind=kind.name)
                                   @ dented, point, atol=1e-12)
