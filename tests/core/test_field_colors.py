"""gencoords.reports.field_colors: viridis for 0..max, a separate ramp for negative coordinates."""

import numpy as np

import gencoords
from gencoords.base import tolerances


def luminance(colors):
    """Relative luminance (Rec. 709) of linear RGB(A) colours."""
    return colors[:, :3] @ np.array([0.2126, 0.7152, 0.0722])


def test_luminance_rises_strictly_from_zero_to_the_maximum():
    values = np.linspace(0.0, 1.0, 1001)
    assert np.all(np.diff(luminance(gencoords.reports.field_colors(values))) > 0.0)


def test_scaled_to_the_field_maximum():
    # a field reaching 0.4 uses the whole map, like one reaching 1
    np.testing.assert_array_equal(gencoords.reports.field_colors(np.linspace(0.0, 0.4, 11)),
                                  gencoords.reports.field_colors(np.linspace(0.0, 1.0, 11)))


def test_negative_values_are_far_from_every_positive_colour():
    positive = gencoords.reports.field_colors(np.linspace(0.0, 1.0, 501))[:, :3]
    negative = gencoords.reports.field_colors(np.concatenate([[1.0], -np.logspace(-8, -1, 200)]))[1:, :3]
    distance = np.linalg.norm(negative[:, None, :] - positive[None, :, :], axis=2)
    assert distance.min() > 0.15  # linear RGB: clearly another colour
    assert np.all(negative[:, 0] > negative[:, 1]) and np.all(negative[:, 0] > negative[:, 2])


def test_negative_ramp_darkens_towards_the_most_negative_value():
    values = np.concatenate([[1.0], -np.linspace(0.001, 0.2, 50)])
    assert np.all(np.diff(luminance(gencoords.reports.field_colors(values)[1:])) < 0.0)


def test_round_off_below_zero_is_zero_not_negative():
    tiny = -0.5 * tolerances.NEGATIVE
    colors = gencoords.reports.field_colors(np.array([1.0, 0.0, tiny]))
    np.testing.assert_array_equal(colors[2], colors[1])
    assert gencoords.reports.field_range([1.0, tiny]) == (0.0, 1.0)


def test_range_and_format():
    values = np.array([-0.05, 0.0, 0.3, 0.7])
    assert gencoords.reports.field_range(values) == (-0.05, 0.7)
    colors = gencoords.reports.field_colors(values)
    assert colors.dtype == np.float32 and colors.shape == (4, 4)
    assert np.all((colors >= 0.0) & (colors <= 1.0)) and np.all(colors[:, 3] == 1.0)
    # a field that is zero everywhere (a far cage vertex) is drawn as zero, not NaN
    assert np.all(np.isfinite(gencoords.reports.field_colors(np.zeros(5))))
