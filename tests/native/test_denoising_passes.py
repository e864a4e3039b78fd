"""Denoising Albedo and Denoising Normal (issue 19): Cycles' passes for the compositor's Denoise
node (OpenImageDenoise). On the unit ball (mu = 0) with one colour: the albedo is that colour times
the coverage, the normal is the Normal pass in Cycles' camera space (x right, y up, z along the
view axis), both averaged over the samples, so edges are anti-aliased as the image is."""
import numpy as np

from conftest import make_camera, render

BALL = dict(mu=(0.0, 0.0, 0.0, 0.0), max_iterations=32, color=(0.8, 0.4, 0.2))
NAMES = ["combined", "alpha", "normal", "denoising_albedo", "denoising_normal"]


def camera_axes(cam):
    m = np.array(cam["matrix"], np.float64)[:3, :3]
    m /= np.linalg.norm(m, axis=0)
    return m[:, 0], m[:, 1], -m[:, 2]   # right, up, forward (-Z of the camera)


def test_one_sample_is_the_normal_pass_in_camera_space():
    cam = make_camera(64, 48)
    p, _ = render(cam, [BALL], names=NAMES)
    right, up, forward = camera_axes(cam)
    n = p["normal"].astype(np.float64)
    expected = np.stack([n @ right, n @ up, n @ forward], -1)
    assert np.max(np.abs(p["denoising_normal"] - expected)) < 1e-6
    hit = p["alpha"][..., 0] == 1.0
    assert hit.sum() > 300
    # Normals face the camera: their component along the view axis is negative.
    assert np.all(p["denoising_normal"][hit][:, 2] < 0.0)
    assert np.all(p["denoising_normal"][~hit] == 0.0)
    # One colour: the albedo is that colour on the ball, black off it.
    assert np.all(p["denoising_albedo"][hit] == np.float32(BALL["color"]))
    assert np.all(p["denoising_albedo"][~hit] == 0.0)


def test_samples_average_albedo_and_normal():
    cam = make_camera(64, 48)
    p, _ = render(cam, [BALL], names=NAMES, shading=dict(samples=4))
    alpha = p["alpha"][..., 0]
    edge = (alpha > 0.0) & (alpha < 1.0)
    assert edge.sum() > 20
    # The albedo is the colour times the coverage (within float32 summing of 4 samples).
    expected = alpha[..., None] * np.float32(BALL["color"])
    assert np.max(np.abs(p["denoising_albedo"] - expected)) < 1e-6
    # Averaged normals: at the edges shorter than 1 by about the coverage; inside close to 1.
    length = np.linalg.norm(p["denoising_normal"], axis=-1)
    assert np.all(length[alpha == 1.0] > 0.99)
    assert np.all(length[edge] <= alpha[edge] + 1e-5)
