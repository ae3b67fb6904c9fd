"""Bad input is refused with a message naming it; results hold at every scale."""

import inspect
import warnings

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import icosphere, octahedron, random_convex_polytope, random_interior_points


def octahedron_point_and_weights():
    vertices, faces = octahedron((1.0, 1.3, 0.8))
    x = np.array([0.1, -0.2, 0.15])
    return vertices, faces, x, gencoords.coordinates(x, vertices, faces, kind="wachspress")[0]


# 1. Floater's functions validate the cage, the points and the targets.

@pytest.mark.parametrize("call", ["weights", "matrix", "scalars"])
def test_floater_functions_refuse_an_open_cage(call):
    vertices, faces, x, w = octahedron_point_and_weights()
    r = len(gencoords.advanced.ridges(faces[:-1]))
    with pytest.raises(gencoords.CageError) as error:
        if call == "weights":
            gencoords.advanced.floater_weights(x[None], vertices, faces[:-1], np.ones((1, r)))
        elif call == "matrix":
            gencoords.advanced.floater_matrix(x[None], vertices, faces[:-1])
        else:
            gencoords.advanced.floater_scalars(x, vertices, faces[:-1], w)
    assert error.value.problem == "open"


@pytest.mark.parametrize("where", ["vertex", "edge", "facet"])
def test_floater_functions_refuse_points_on_the_boundary_with_a_clear_error(where):
    vertices, faces, _, _ = octahedron_point_and_weights()
    x = {"vertex": vertices[0], "edge": 0.5 * (vertices[0] + vertices[2]),
         "facet": vertices[faces[0]].mean(axis=0)}[where]
    w = np.eye(len(vertices))[0]
    with pytest.raises(ValueError, match="pole on the cage's facet hyperplanes"):
        gencoords.advanced.floater_scalars(x, vertices, faces, w)
    with pytest.raises(ValueError, match="pole"):
        gencoords.advanced.floater_matrix(x[None], vertices, faces)
    with pytest.raises(ValueError, match="pole"):
        gencoords.advanced.floater_weights(x[None], vertices, faces, np.ones((1, len(gencoords.advanced.ridges(faces)))))


def test_floater_scalars_of_the_wrong_length_or_inconsistent_targets_are_refused():
    vertices, faces, x, w = octahedron_point_and_weights()
    with pytest.raises(ValueError, match=r"w must have shape \(n,\) = \(6,\)"):
        gencoords.advanced.floater_scalars(x, vertices, faces, w[:-1])
    with pytest.raises(ValueError, match=r"c must have shape \(k, r\) = \(1, 12\)"):
        gencoords.advanced.floater_weights(x[None], vertices, faces, np.ones((1, 11)))
    bent = w.copy()
    bent[0] += 0.3  # no longer reproduces x: no Floater scalars give it
    with pytest.raises(ValueError, match="not homogeneous"):
        gencoords.advanced.floater_scalars(x, vertices, faces, bent)
    # Consistent targets still round-trip (the check does not refuse rounding noise).
    c = gencoords.advanced.floater_scalars(x, vertices, faces, w * 1e6)
    np.testing.assert_allclose(gencoords.advanced.floater_weights(x[None], vertices, faces, c[None])[0], w * 1e6,
                               rtol=1e-9)


# 2. Tolerances that cannot be meant are refused, stating the accepted range.

@pytest.mark.parametrize("tolerance", [0.1, 0.5, 2e-3, "1e-3", 0.0, -1e-9, np.nan, np.inf, True, None,
                                       1j])
def test_tolerances_outside_the_accepted_range_are_refused(tolerance):
    vertices, faces = icosphere(1)
    for call in (lambda: gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, tolerance=tolerance),
                 lambda: gencoords.point_locations([[0.1, 0.0, 0.0]], vertices, faces, tolerance=tolerance),
                 lambda: gencoords.advanced.validate_cage(vertices, faces, tolerance=tolerance)):
        with pytest.raises(ValueError, match=r"tolerance must be a number in \(0, 0.001\]"):
            call()


def test_the_largest_accepted_tolerance_still_works():
    vertices, faces = icosphere(1)
    points = 0.5 * random_interior_points(np.random.default_rng(0), vertices, 20)
    result = gencoords.coordinates(points, vertices, faces, tolerance=gencoords.base.tolerances.LARGEST)
    np.testing.assert_allclose(result @ vertices, points, atol=1e-12)


# 3. Dtypes and shapes are checked at the entry.

def test_result_dtype_must_be_a_float():
    vertices, faces = octahedron()
    for dtype in (np.int32, np.complex128, "garbage", bool):
        with pytest.raises(ValueError, match="dtype must be numpy.float32 or numpy.float64"):
            gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, dtype=dtype)
    assert gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, dtype="float32").dtype == np.float32


def test_complex_input_is_refused_not_cast():
    vertices, faces = octahedron()
    with pytest.raises(ValueError, match="points must be real numbers, got complex"):
        gencoords.coordinates([[0.1 + 1e-3j, 0.0, 0.0]], vertices, faces)
    with pytest.raises(ValueError, match="vertices must be real numbers, got complex"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices.astype(complex), faces)


def test_locations_are_checked_before_any_work():
    vertices, faces = octahedron()
    points = np.zeros((3, 3))
    calls = []
    for locations, message in [(np.empty(2, np.int8), r"shape \(3,\)"), ([0, 0, 0], r"shape \(3,\)"),
                               (np.empty(3, np.uint8), "signed integer or float"),
                               (np.empty(3, np.int8)[::-1].copy().view(np.int8), None)]:
        if message is None:  # a good one, then the same made read-only
            gencoords.coordinates(points, vertices, faces, locations=locations, progress=calls.append)
            locations.flags.writeable = False
            message = "writable"
            calls.clear()
        with pytest.raises(ValueError, match=message):
            gencoords.coordinates(points, vertices, faces, locations=locations, progress=calls.append)
        assert calls == []  # refused before the first chunk


# 4. Results are scale invariant at every representable scale; beyond it, a clear refusal.

SCALES = [1e-300, 1e-200, 1e-150, 1e-60, 1.0, 1e70, 1e100, 1e150, 1e200, 1e300]


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10), (4, 8)])
def test_coordinates_are_the_same_at_every_scale(dim, count):
    rng = np.random.default_rng(dim)
    vertices, faces = random_convex_polytope(rng, dim, count)
    points = np.concatenate([random_interior_points(rng, vertices, 15), vertices[:2],
                             vertices[faces[0]].mean(axis=0)[None], vertices.mean(axis=0)[None] + 5.0])
    for kind in gencoords.advanced.KINDS:
        reference = gencoords.coordinates(points, vertices, faces, kind=kind, outside="extrapolate")
        for scale in SCALES:
            scaled = gencoords.coordinates(points * scale, vertices * scale, faces, kind=kind, outside="extrapolate")
            np.testing.assert_allclose(scaled, reference, atol=1e-12, err_msg=f"{kind} at {scale:g}")
        np.testing.assert_array_equal(gencoords.point_locations(points * scale, vertices * scale, faces),
                                      gencoords.point_locations(points, vertices, faces))


@pytest.mark.parametrize("scale", [1e-150, 1e-60, 1e60, 1e150])
def test_raw_values_are_in_world_units_at_every_scale(scale):
    """Weights, ridge scalars and Floater's values scale with their length degree."""
    vertices, faces = octahedron((1.0, 1.3, 0.8))
    x = np.array([[0.1, -0.2, 0.15]])
    degree = {"mean_value": 0, "discrete_harmonic": 2, "voronoi": 2, "wachspress": -2}
    for kind, power in degree.items():
        unit = gencoords.advanced.ridge_scalars(x, vertices, faces, kind)
        scaled = gencoords.advanced.ridge_scalars(x * scale, vertices * scale, faces, kind)
        np.testing.assert_allclose(scaled, unit * scale ** power, rtol=1e-12)
        if abs(np.log10(scale) * (power - 1)) > 300:  # weights beyond float64: refused
            with pytest.raises(ValueError, match="overflow or underflow float64"):
                gencoords.weights(x * scale, vertices * scale, faces, kind=kind)
            continue
        weights = gencoords.weights(x * scale, vertices * scale, faces, kind=kind)
        np.testing.assert_allclose(weights, gencoords.weights(x, vertices, faces, kind=kind) * scale ** (power - 1),
                                   rtol=1e-12)
    if abs(np.log10(scale)) > 100:  # c scales as size^3
        return
    c = gencoords.advanced.floater_scalars(x[0] * scale, vertices * scale, faces, gencoords.weights(x, vertices, faces, "voronoi")[0])
    np.testing.assert_allclose(c, gencoords.advanced.floater_scalars(x[0], vertices, faces,
                                                       gencoords.weights(x, vertices, faces, "voronoi")[0]) * scale ** 3,
                               rtol=1e-10)


def test_beyond_float64s_range_the_cage_or_points_are_refused():
    vertices, faces = octahedron()
    with pytest.raises(gencoords.CageError, match="outside the range float64 can compute with") as error:
        gencoords.coordinates([[0.0, 0.0, 0.0]], vertices * 1.5e308, faces)
    assert error.value.problem == "scale"
    with pytest.raises(gencoords.CageError, match="outside the range"):
        gencoords.coordinates([[0.0, 0.0, 0.0]], vertices * 1e-310, faces)
    with pytest.raises(ValueError, match="more than 1e\\+30 times the cage's size"):
        gencoords.coordinates([[1e35, 0.0, 0.0]], vertices, faces, outside="project")


# 5. Mean value extrapolation outside a near-flat cage warns that it lost accuracy.

def test_extrapolating_outside_a_flat_cage_warns_with_an_error_estimate():
    vertices, faces = icosphere(1)
    points = np.random.default_rng(0).uniform(-2.0, 2.0, (50, 3)) * [1.0, 1.0, 0.5]
    with pytest.warns(gencoords.AccuracyWarning, match="accurate only to about"):
        gencoords.coordinates(points, vertices * [1.0, 1.0, 1e-6], faces, kind="mean_value", outside="extrapolate")
    with warnings.catch_warnings():  # a thick cage, or projection, or no outside point: silence
        warnings.simplefilter("error")
        gencoords.coordinates(points, vertices, faces, kind="mean_value", outside="extrapolate")
        gencoords.coordinates(points, vertices * [1.0, 1.0, 1e-6], faces, kind="mean_value", outside="project")
        gencoords.coordinates(0.1 * points * [1.0, 1.0, 1e-6], vertices * [1.0, 1.0, 1e-6], faces,
                         kind="mean_value", outside="extrapolate")
        gencoords.coordinates(points, vertices * [1.0, 1.0, 0.5e-2], faces, kind="mean_value",
                         outside="extrapolate")  # flat enough to check, accurate enough to pass


# 6. Every public function checks its inputs the same way (gencoords.base.inputs).

def good_calls():
    """A valid call of every public function that takes arrays: name -> keyword arguments."""
    vertices, faces = octahedron((1.0, 1.3, 0.8))
    points = np.array([[0.1, -0.2, 0.15], [0.0, 0.3, -0.1]])
    ones = np.ones((2, len(gencoords.advanced.ridges(faces))))
    coordinates = gencoords.coordinates(points, vertices, faces)
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    cage = dict(points=points, vertices=vertices, faces=faces)
    return {
        "coordinates": cage, "weights": cage, "point_locations": cage, "floater_matrix": cage,
        "ridges": dict(faces=faces),
        "ridge_scalars": dict(cage, kind="voronoi"),
        "weights_from_ridge_scalars": dict(cage, d=ones),
        "floater_weights": dict(cage, c=ones),
        "ridge_scalars_from_floater": dict(cage, c=ones),
        "floater_from_ridge_scalars": dict(cage, d=ones),
        "floater_scalars": dict(point=points[0], vertices=vertices, faces=faces, w=coordinates[0]),
        "validate_cage": dict(vertices=vertices, faces=faces),
        "concave_facets": dict(vertices=vertices, faces=faces),
        "linear_precision": dict(coordinates=coordinates, vertices=vertices, points=points),
        "orient_facets_outward": dict(vertices=vertices, facets=faces),
        "triangulate_quads": dict(vertices=cube, quads=quads),
        "deform": dict(coordinates=coordinates, cage_positions=vertices, out=np.empty((2, 3))),
        "field_colors": dict(values=coordinates[:, 0]),
        "field_range": dict(values=coordinates[:, 0]),
        "coordinate_report": dict(cage, kind="power", gamma=0.5, samples=40),
        "ridge_scalars_from_surface": dict(cage, radius=lambda x, u: np.ones(u.shape[:2]), levels=1),
        "coordinate_summary": dict(coordinates=coordinates),
        "green_coordinates": cage,
        "green_deform": dict(zip(("phi", "psi"), gencoords.green_coordinates(points, vertices, faces)),
                             vertices=vertices, cage_positions=vertices, faces=faces),
        "stretch_factors": dict(vertices=vertices, cage_positions=vertices, faces=faces),
        "harmonic_coordinates": dict(cage, resolution=8),
        "harmonic_field": dict(vertices=vertices, faces=faces, resolution=8),
        "mean_value_quad_coordinates": dict(points=np.array([[0.5, 0.5, 0.5], [0.3, 0.4, 0.6]]), vertices=cube,
                                            polygons=quads),
        "harmonic_quad_field": dict(vertices=cube, polygons=quads, resolution=8),
    }


def bad_versions(array):
    """(what, bad array) pairs: NaN, a wrong shape, a wrong dtype, complex values."""
    yield "wrong shape", array[None]
    yield "complex", array.astype(np.complex128)
    if array.dtype.kind == "f":
        broken = array.copy()
        broken.flat[-1] = np.nan
        yield "NaN", broken
        yield "wrong dtype", array.astype(str)
    else:
        yield "wrong dtype", array.astype(np.float64)


# What each parameter is called in messages (a vertex, a face...).
NAMED_AS = {"vertices": "vert", "faces": "face", "facets": "facet", "quads": "quad", "points": "point",
            "point": "point", "c": "c must", "d": "d must", "w": "w must", "coordinates": "coordinates",
            "cage_positions": "cage_positions", "out": "out must", "values": "values", "phi": "phi",
            "psi": "psi", "polygons": "polygon"}


def test_every_public_function_checks_its_inputs():
    calls = good_calls()
    apis = (gencoords, *gencoords.SUB_APIS)  # the top level and the named sub-APIs
    public = [getattr(api, name) for api in apis for name in api.__all__ if callable(getattr(api, name))
              and not isinstance(getattr(api, name), type) and not inspect.ismodule(getattr(api, name))]
    by_name = {function.__name__: function for function in public}
    for function in public:
        assert getattr(function, "checks_inputs", False), f"{function.__name__} is not @checked"
    takes_arrays = {f.__name__ for f in public} - {"needs_convex"}
    assert takes_arrays == set(calls), "every public function taking arrays has a good call here"
    for name, arguments in calls.items():
        function = by_name[name]
        function(**arguments)  # the good call works
        for parameter, value in arguments.items():
            if not isinstance(value, np.ndarray):
                continue
            for what, bad in bad_versions(value):
                if parameter == "out" and what == "NaN":
                    continue  # an output buffer: its contents are overwritten
                with pytest.raises(ValueError) as error:
                    function(**dict(arguments, **{parameter: bad}))
                assert NAMED_AS[parameter] in str(error.value), (name, parameter, what, str(error.value))
        if "tolerance" in inspect.signature(function).parameters:
            for tolerance in (0.5, "1e-3", np.nan):
                with pytest.raises(ValueError, match=r"tolerance must be a number in \(0, 0.001\]"):
                    function(**dict(arguments, tolerance=tolerance))


def test_every_cage_method_checks_its_inputs():
    vertices, faces = octahedron((1.0, 1.3, 0.8))
    points = np.array([[0.1, -0.2, 0.15], [0.0, 0.3, -0.1]])
    cage = gencoords.Cage(vertices, faces)
    methods = [cage.coordinates, cage.green_coordinates, cage.weights, cage.ridge_scalars, cage.point_locations]
    for method in methods + [cage.suggested_workers]:
        assert getattr(method, "checks_inputs", False), f"Cage.{method.__name__} is not @checked"
    for method in methods:
        arguments = dict(points=points, **({"kind": "voronoi"} if method == cage.ridge_scalars else {}))
        method(**arguments)
        for what, bad in bad_versions(points):
            with pytest.raises(ValueError, match="point"):
                method(**dict(arguments, points=bad))
    with pytest.raises(ValueError, match="dtype must be"):
        cage.coordinates(points, dtype=np.int32)
    with pytest.raises(ValueError, match="workers must be a positive integer"):
        cage.coordinates(points, workers=0)


def test_a_function_with_an_unchecked_parameter_cannot_be_declared():
    with pytest.raises(TypeError, match="no input check for parameter"):
        gencoords.base.inputs.checked(lambda points, colour: None)
