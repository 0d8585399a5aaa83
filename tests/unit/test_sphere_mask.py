"""The pixels image figures are taken over: the canonical sphere's, not the background's. The
renders' alpha is 1 everywhere (the world is rendered), so the mask is geometric; a mask of every
pixel let the background (identical in every render) dilute every figure of the image benches."""
import math

import numpy as np
import pytest

from lamella_dev.bench.image_references import sphere_mask, sphere_pixels


@pytest.mark.parametrize("res", [48, 64, 128])
def test_the_mask_is_the_sphere_inside_its_silhouette(res):
    m = sphere_pixels(res)
    # the sphere (radius 1) fills pi / 2.2^2 = 0.649 of the orthographic frame; the mask keeps
    # what lies inside 0.985 of its radius
    assert abs(m.mean() - math.pi * 0.97 / 2.2 ** 2) < 0.02
    assert m[res // 2, res // 2] and not m[0, 0] and not m[0, res // 2] and not m[res // 2, 0]
    assert (m == m[::-1]).all() and (m == m[:, ::-1]).all()


def test_an_opaque_render_gets_the_sphere_not_every_pixel():
    rgba = np.ones((64, 64, 4), np.float32)  # alpha 1 everywhere, as every canonical render
    m = sphere_mask(rgba)
    assert 0.5 < m.mean() < 0.7
    with pytest.raises(ValueError, match="square"):
        sphere_mask(np.ones((64, 32, 4)))
